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

from clothtool.solver.frame import FrameStacks
from clothtool.solver.framefn import FusedCall, stacked, standing
from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.kernels.integrate import integrate_affine, integrate_free, integrate_linear
from clothtool.solver.stage import Stage


class IntegrateStage(Stage):
    name = "integrate"

    def __init__(self, solver):
        super().__init__(solver)
        # what holds the cloth does not change during a bake
        self.free = self._free_cloth()
        self.mean = np.zeros(3, np.float64)  # integrate_free's mean displacement
        self._scales_of, self._h_of = None, None  # what begin_frame's values were computed from
        # a moving frame's terms: the stacks they are rows of and the frame's first row in
        # them (FrameStacks: the same arrays from frame to frame, so the fused call stands)
        self.terms_stacks: FrameStacks | None = None
        self.row = np.zeros(1, np.int64)
        self._fused: FusedCall | None = None

    def begin_frame(self, plan: FramePlan) -> None:
        terms = self.solver.frame_terms
        if terms is not None:
            self.terms_stacks = terms.stacks
            self.row[0] = self.terms_stacks.first
        if self.solver.frame_scales is self._scales_of and plan.h == self._h_of:
            return  # the solver's scales and h as last frame: the same values
        self._scales_of, self._h_of = self.solver.frame_scales, plan.h
        self.real = self.solver.state.cur.dtype.type  # float32, or float64 for references
        self.gravity_bias = (self.solver.gravity * plan.h * plan.h).astype(self.real)
        self.scales = stacked(self.solver.frame_scales, self.real)  # per iteration, for integrate_linear
        # the damping's share of a free cloth's mean motion, r - scale per iteration, in float64
        # (scale may be a float32, and r - scale rounded to float32 would leak ~1e-8 of the momentum)
        self.spared = self.solver.frame_ratios - self.solver.frame_scales

    def _free_cloth(self) -> bool:
        """True when nothing holds the cloth (module docstring): its damping then spares its
        mean motion."""
        solver, model = self.solver, self.solver.model
        return bool(
            solver.track is None
            and solver.attachment is None
            and model.backstop_centers is None
            and (model.inv_mass > 0).all()
            and not np.isfinite(model.max_distance).any()
        )

    def warm_up(self) -> None:
        state = self.solver.state
        real = state.cur.dtype.type
        if self.solver.track is None:  # run() integrates in a moving frame exactly when the cloth follows a track
            integrate_linear(real(1.0), np.zeros(3, real), state.cur[:0], state.prev[:0])
            if self.free:
                integrate_free(real(1.0), 0.5, np.zeros(3, real), np.zeros(3, np.float64), state.cur[:0], state.prev[:0])
        else:
            eye = np.eye(3, dtype=real)
            integrate_affine(eye, eye, np.zeros(3, real), state.cur[:0], state.prev[:0])

    def run(self, iteration: Iteration) -> None:
        state = self.solver.state
        terms = self.solver.frame_terms
        if terms is None:
            i = iteration.index
            if self.free:
                integrate_free(self.scales[i], self.spared[i], self.gravity_bias, self.mean, state.cur, state.prev)
            else:
                integrate_linear(self.scales[i], self.gravity_bias, state.cur, state.prev)
        else:
            i = iteration.index
            integrate_affine(terms.m_cur[i], terms.m_prev[i], terms.bias[i], state.cur, state.prev)

    def fused_call(self) -> FusedCall:
        stacks = self.terms_stacks
        call: tuple
        if self.solver.frame_terms is not None and stacks is not None:
            call = (_AFFINE, _AFFINE_NAMES, (stacks.m_cur, stacks.m_prev, stacks.bias, self.row), _AFFINE_KERNEL)
        elif self.free:
            call = (_FREE, _FREE_NAMES, (self.scales, self.spared, self.gravity_bias, self.mean), _FREE_KERNEL)
        else:
            call = (_LINEAR, _LINEAR_NAMES, (self.scales, self.gravity_bias), _LINEAR_KERNEL)
        self._fused = standing(self._fused, *call)
        return self._fused


# the fused calls' lines and kernels (the same objects every frame: framefn.standing)
_AFFINE = ("{integrate}({m_cur}[{row}[0] + it], {m_prev}[{row}[0] + it], {bias}[{row}[0] + it], cur, prev)",)
_AFFINE_NAMES = ("m_cur", "m_prev", "bias", "row")
_AFFINE_KERNEL = {"integrate": integrate_affine}
_FREE = ("{integrate}({scales}[it], {spared}[it], {gravity_bias}, {mean}, cur, prev)",)
_FREE_NAMES = ("scales", "spared", "gravity_bias", "mean")
_FREE_KERNEL = {"integrate": integrate_free}
_LINEAR = ("{integrate}({scales}[it], {gravity_bias}, cur, prev)",)
_LINEAR_NAMES = ("scales", "gravity_bias")
_LINEAR_KERNEL = {"integrate": integrate_linear}
