"""Stage: Verlet integration with damping, the time-step ratio and the frame's motion."""

from __future__ import annotations

import numpy as np

from clothtool.solver.framefn import FusedCall, stacked
from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.kernels.integrate import integrate_affine, integrate_linear
from clothtool.solver.stage import Stage


class IntegrateStage(Stage):
    name = "integrate"

    def begin_frame(self, plan: FramePlan) -> None:
        self.real = self.solver.state.cur.dtype.type  # float32, or float64 for references
        self.gravity_bias = (self.solver.gravity * plan.h * plan.h).astype(self.real)
        self.scales = stacked(self.solver.frame_scales, self.real)  # per iteration, for integrate_linear

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
        terms = self.solver.frame_terms
        if terms is None:
            integrate_linear(self.scales[iteration.index], self.gravity_bias, state.cur, state.prev)
        else:
            i = iteration.index
            integrate_affine(terms.m_cur[i], terms.m_prev[i], terms.bias[i], state.cur, state.prev)

    def fused_call(self) -> FusedCall:
        terms = self.solver.frame_terms
        if terms is None:
            return FusedCall(
                ("{integrate}({scales}[it], {gravity_bias}, cur, prev)",),
                {"scales": self.scales, "gravity_bias": self.gravity_bias},
                {"integrate": integrate_linear},
            )
        return FusedCall(
            ("{integrate}({m_cur}[it], {m_prev}[it], {bias}[it], cur, prev)",),
            {"m_cur": terms.m_cur, "m_prev": terms.m_prev, "bias": terms.bias},
            {"integrate": integrate_affine},
        )
