"""Stage: Verlet integration with damping, the time-step ratio and the frame's motion."""

from __future__ import annotations

import numpy as np

from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.kernels.integrate import integrate_affine, integrate_linear
from clothtool.solver.stage import Stage


class IntegrateStage(Stage):
    name = "integrate"

    def begin_frame(self, plan: FramePlan) -> None:
        self.gravity_bias = (self.solver.gravity * plan.h * plan.h).astype(np.float32)

    def warm_up(self) -> None:
        state = self.solver.state
        integrate_linear(np.float32(1.0), np.zeros(3, np.float32), state.cur[:0], state.prev[:0])
        eye = np.eye(3, dtype=np.float32)
        integrate_affine(eye, eye, np.zeros(3, np.float32), state.cur[:0], state.prev[:0])

    def run(self, iteration: Iteration) -> None:
        state = self.solver.state
        if iteration.terms is None:
            integrate_linear(np.float32(iteration.scale), self.gravity_bias, state.cur, state.prev)
        else:
            terms = iteration.terms
            integrate_affine(terms.m_cur, terms.m_prev, terms.bias, state.cur, state.prev)
