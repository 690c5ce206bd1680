"""Stage: Verlet integration with damping, the time-step ratio and the frame's motion."""

from __future__ import annotations

import numpy as np

from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.kernels.integrate import integrate_affine, integrate_linear
from clothtool.solver.stage import Stage


class IntegrateStage(Stage):
    name = "integrate"

    def begin_frame(self, plan: FramePlan) -> None:
        self.real = self.solver.state.cur.dtype.type  # float32, or float64 for references
        self.gravity_bias = (self.solver.gravity * plan.h * plan.h).astype(self.real)

    def warm_up(self) -> None:
        state = self.solver.state
        real = state.cur.dtype.type
        if self.solver.track is None:  # run() integrates in a moving frame exactly when the cloth follows a track
            integrate_linear(real(1.0), np.zeros(3, real), state.cur[:0], state.prev[:0])
        else:
            eye = np.eye(3, dtype=real)
            integrate_affine(eye, eye, np.zeros(3, real), state.cur[:0], state.prev[:0])

    def run(self, iteration: Iteration) -> None:
        state = self.solver.state
        if iteration.terms is None:
            integrate_linear(self.real(iteration.scale), self.gravity_bias, state.cur, state.prev)
        else:
            terms = iteration.terms
            integrate_affine(terms.m_cur, terms.m_prev, terms.bias, state.cur, state.prev)
