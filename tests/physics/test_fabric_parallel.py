"""solver.fabric_parallel_threshold picks the fabric kernel, never the result: a cloth swung
for a second gives the same bits with its sets solved on one core or on all."""

from __future__ import annotations

import numpy as np

from clothtool.settings import SolverConfig
from clothtool.solver.kernels.fabric import solve_phases, solve_phases_parallel, solve_xpbd, solve_xpbd_parallel


def test_threshold_selects_the_kernel_and_keeps_the_bits(grid_fabric, solver_for, simulate):
    fabric = grid_fabric(24, 24, 0.04, plane="XZ", pin_box=(-1.0, -1.0, -1.0, 1.0, 1.0, 0.01))
    largest = int(np.diff(fabric.set_offsets).max())
    for mode, serial, parallel in (("nvcloth", solve_phases, solve_phases_parallel), ("xpbd", solve_xpbd, solve_xpbd_parallel)):
        positions = []
        for threshold, kernel in ((largest + 1, serial), (1, parallel)):
            solver = solver_for(fabric, config=SolverConfig(stiffness_mode=mode, fabric_parallel_threshold=threshold))
            fabric_stage = next(stage for stage in solver.stages if stage.name == "fabric")
            assert fabric_stage.kernel is kernel
            simulate(solver, 60.0, 60)
            positions.append(solver.world_points())
        assert np.abs(positions[0] - fabric.rest_pos).max() > 0.1  # it swung
        np.testing.assert_array_equal(positions[0], positions[1])
