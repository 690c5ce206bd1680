"""Stage: Verlet integration with damping, the time-step ratio and the frame's motion.

Damping acts on the velocity relative to what holds the cloth. A cloth held by pins,
attachments, motion constraints, backstops or a track is damped in its own frame, as NvCloth
does (its pins' frame). A free cloth (nothing holds it) is damped relative to its own mean
motion: v' = v_mean + k (v - v_mean), k the fraction kept. Damping the absolute velocity of a
free cloth braked a uniformly drifting cloth and changed its momentum, where the implicit and
explicit integrators, whose damping acts on strain rates, conserve it
(tests/physics/test_behaviour_table.py, momentum row). In Verlet form, with the step ratio r
(scale = k r): x' = x + scale (x - x_prev) + (r - scale) D + g h^2, D the mass-weighted mean of
x - x_prev, so that sum m x' - sum m x = r sum m (x - x_prev) + M g h^2 exactly.
"""

from __future__ import annotations

import numpy as np

from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.kernels.integrate import integrate_affine, integrate_linear, mean_displacement
from clothtool.solver.stage import Stage


class IntegrateStage(Stage):
    name = "integrate"

    def begin_frame(self, plan: FramePlan) -> None:
        self.real = self.solver.state.cur.dtype.type  # float32, or float64 for references
        self.gravity_bias = (self.solver.gravity * plan.h * plan.h).astype(self.real)
        if not hasattr(self, "free"):  # what holds the cloth does not change during a bake
            self.free = self._free_cloth()
            self.mean = np.zeros(3, np.float64)

    def _free_cloth(self) -> bool:
        """True when nothing holds the cloth (module docstring): its damping then spares its
        mean motion."""
        solver, model = self.solver, self.solver.model
        return bool(
            solver.track is None
            and getattr(solver, "attachment", None) is None
            and model.backstop_centers is None
            and (model.inv_mass > 0).all()
            and not np.isfinite(model.max_distance).any()
        )

    def warm_up(self) -> None:
        state = self.solver.state
        real = state.cur.dtype.type
        if self.solver.track is None:  # run() integrates in a moving frame exactly when the cloth follows a track
            integrate_linear(real(1.0), np.zeros(3, real), state.cur[:0], state.prev[:0])
            mean_displacement(state.cur[:0], state.prev[:0], np.zeros(3, np.float64))
        else:
            eye = np.eye(3, dtype=real)
            integrate_affine(eye, eye, np.zeros(3, real), state.cur[:0], state.prev[:0])

    def run(self, iteration: Iteration) -> None:
        state = self.solver.state
        if iteration.terms is None:
            bias = self.gravity_bias
            # r - scale, the damping's share of the mean motion, in float64 (scale may be a
            # float32, and r - scale rounded to float32 would leak ~1e-8 of the momentum)
            spared = float(iteration.ratio) - float(iteration.scale)
            if self.free and spared != 0.0:
                mean_displacement(state.cur, state.prev, self.mean)
                bias = (self.gravity_bias + spared * self.mean).astype(self.real)
            integrate_linear(self.real(iteration.scale), bias, state.cur, state.prev)
        else:
            terms = iteration.terms
            integrate_affine(terms.m_cur, terms.m_prev, terms.bias, state.cur, state.prev)
