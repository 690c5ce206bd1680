"""Stage: wind, drag and lift per triangle (the seed's applyWind)."""

from __future__ import annotations

import numpy as np

from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.kernels.wind import apply_wind
from clothtool.solver.logstiffness import iteration_stiffness
from clothtool.solver.stage import Stage

_NO_MOTION = (np.zeros((3, 3), np.float32), np.zeros(3, np.float32))


class WindStage(Stage):
    name = "wind"

    def begin_frame(self, plan: FramePlan) -> None:
        solver = self.solver
        material = solver.model.material
        f = solver.config.stiffness_frequency
        # drag and lift coefficients are per stiffness-frequency step, like stiffness (NvCloth)
        self.drag = iteration_stiffness(material.drag_coefficient, f, plan.h)
        self.lift = iteration_stiffness(material.lift_coefficient, f, plan.h)
        self.inv_dt = np.float32(1.0 / plan.h)
        self.density = np.float32(solver.environment.fluid_density)
        self.wind_world = solver.environment.wind_at(plan.time) * plan.h

    def warm_up(self) -> None:
        solver = self.solver
        matrix, offset = _NO_MOTION
        one = np.float32(1.0)
        apply_wind(solver.model.triangles[:0], matrix, offset, offset, one, one, one, one, solver.state.cur, solver.state.prev)

    def run(self, iteration: Iteration) -> None:
        solver = self.solver
        if iteration.terms is None:
            matrix, offset = _NO_MOTION
            air = self.wind_world.astype(np.float32)
        else:
            matrix, offset = iteration.terms.motion_matrix, iteration.terms.motion_offset
            air = (iteration.terms.to_local @ self.wind_world).astype(np.float32)
        apply_wind(
            solver.model.triangles, matrix, offset, air, self.inv_dt, self.drag, self.lift, self.density,
            solver.state.cur, solver.state.prev,
        )
