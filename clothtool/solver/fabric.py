"""Stage: the fabric's constraint phases, set by set (log-space stiffness, NvCloth)."""

from __future__ import annotations

import numpy as np

from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.kernels.fabric import solve_phases, solve_phases_parallel
from clothtool.solver.logstiffness import iteration_multiplier, iteration_stiffness, limit_term
from clothtool.solver.stage import Stage


class FabricStage(Stage):
    name = "fabric"

    def __init__(self, solver):
        super().__init__(solver)
        model = solver.model
        set_sizes = np.diff(model.set_offsets)
        # thread start-up costs more than it saves on small sets; results are identical
        big = set_sizes.size and set_sizes.max() >= solver.config.parallel_threshold
        self.kernel = solve_phases_parallel if big else solve_phases
        self.params = np.zeros((len(model.phase_labels), 4), np.float32)

    def begin_frame(self, plan: FramePlan) -> None:
        material = self.solver.model.material
        f = self.solver.config.stiffness_frequency
        for p, label in enumerate(self.solver.model.phase_labels):
            phase = material.phase(label)
            self.params[p] = (
                iteration_stiffness(phase.stiffness, f, plan.h),
                iteration_multiplier(phase.stiffness_multiplier, f, plan.h),
                limit_term(phase.compression_limit),
                limit_term(phase.stretch_limit),
            )

    def warm_up(self) -> None:
        model = self.solver.model
        self.kernel(
            model.constraint_indices, model.constraint_rest_length, model.constraint_stiffness,
            model.set_offsets, model.phase_set_offsets, self.params[:0], self.solver.state.cur,
        )

    def run(self, iteration: Iteration) -> None:
        model = self.solver.model
        self.kernel(
            model.constraint_indices, model.constraint_rest_length, model.constraint_stiffness,
            model.set_offsets, model.phase_set_offsets, self.params, self.solver.state.cur,
        )
