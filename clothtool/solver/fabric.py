"""Stage: the fabric's constraint phases, set by set.

Two stiffness modes:
* ``nvcloth``: NvCloth's edge constraints with log-space stiffness per phase at the
  stiffness frequency, stiffness multiplier and compression/stretch limits (the seed's
  pseudo-code; NvCloth also converts the multiplier in log space, which the seed omits);
* ``xpbd``: compliance from the material's physical moduli (XPBD with one iteration per
  substep), which converges to the same sag, stretch and oscillation frequency as the
  solver frequency rises.
"""

from __future__ import annotations

import numpy as np

from clothtool.solver.framefn import FusedCall
from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.kernels.fabric import solve_phases, solve_phases_parallel, solve_xpbd, solve_xpbd_parallel
from clothtool.solver.logstiffness import iteration_multiplier, iteration_stiffness, limit_term
from clothtool.solver.stage import Stage

STRETCH_LABELS = ("vertical", "horizontal")


def constraint_compliance(model) -> np.ndarray:
    """f64 (c,) XPBD compliance of each constraint (1 / stiffness, m/N).

    A stretch or shear constraint of rest length L between particles of lumped areas a, b
    models a strip of material of area A = (a + b) / 2: its spring constant is
    k = modulus * A / L^2 (N/m), which on a regular grid gives a sheet the material's
    stretch modulus exactly. Bending distance constraints get k = bend_modulus * A / L^4, a
    dimensional mapping (a distance constraint across a hinge resists bending only to second
    order, so no exact mapping exists). Painted per-constraint stiffness scales k.
    """
    material = model.material
    areas = model.fabric.particle_area.astype(np.float64)
    pairs = model.constraint_indices
    area = 0.5 * (areas[pairs[:, 0]] + areas[pairs[:, 1]])
    length_m = model.constraint_rest_length.astype(np.float64) * model.units_to_meters
    length_m = np.maximum(length_m, 1e-9)
    k = np.zeros(pairs.shape[0])
    for p, label in enumerate(model.phase_labels):
        first = model.set_offsets[model.phase_set_offsets[p]]
        last = model.set_offsets[model.phase_set_offsets[p + 1]]
        span = slice(first, last)
        if label in STRETCH_LABELS:
            k[span] = material.stretch_modulus * area[span] / length_m[span] ** 2
        elif label == "shearing":
            k[span] = material.shear_modulus * area[span] / length_m[span] ** 2
        else:
            k[span] = material.bend_modulus * area[span] / length_m[span] ** 4
    k *= model.constraint_stiffness
    # No unit conversion: with masses in kg and lengths in scene units (s metres each), forces
    # are in kg units/s^2 = N/s and Hooke's law F = k C keeps the same k (N/m) in both units.
    with np.errstate(divide="ignore"):
        return np.where(k > 0, 1.0 / k, np.inf)


class FabricStage(Stage):
    name = "fabric"

    def __init__(self, solver):
        super().__init__(solver)
        model = solver.model
        set_sizes = np.diff(model.set_offsets)
        # thread start-up costs more than it saves on small sets; results are identical
        big = bool(set_sizes.size and set_sizes.max() >= solver.config.fabric_parallel_threshold)
        self.xpbd = solver.config.stiffness_mode == "xpbd"
        if self.xpbd:
            self.kernel = solve_xpbd_parallel if big else solve_xpbd
            # float32 max stands in for an infinite compliance (a constraint with no stiffness)
            self.compliance = np.minimum(constraint_compliance(model), np.finfo(np.float32).max)
            self.alpha_tilde = np.zeros(model.constraint_indices.shape[0], np.float32)
        else:
            self.kernel = solve_phases_parallel if big else solve_phases
            self.params = np.zeros((len(model.phase_labels), 4), np.float32)
        self.params_h = None  # the iteration length the parameters were converted for

    def begin_frame(self, plan: FramePlan) -> None:
        # Frames of one bake usually share their iteration length: convert only when it changes.
        if plan.h == self.params_h:
            return
        self.params_h = plan.h
        if self.xpbd:
            self.alpha_tilde[:] = np.minimum(self.compliance / (plan.h * plan.h), np.finfo(np.float32).max)
            return
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
        if self.xpbd:
            self.kernel(model.constraint_indices, model.constraint_rest_length, self.alpha_tilde, model.set_offsets[:1], self.solver.state.cur)
        else:
            self.kernel(
                model.constraint_indices, model.constraint_rest_length, model.constraint_stiffness,
                model.set_offsets, model.phase_set_offsets, self.params[:0], self.solver.state.cur,
            )

    def run(self, iteration: Iteration) -> None:
        model = self.solver.model
        if self.xpbd:
            self.kernel(model.constraint_indices, model.constraint_rest_length, self.alpha_tilde, model.set_offsets, self.solver.state.cur)
        else:
            self.kernel(
                model.constraint_indices, model.constraint_rest_length, model.constraint_stiffness,
                model.set_offsets, model.phase_set_offsets, self.params, self.solver.state.cur,
            )

    def fused_call(self) -> FusedCall:
        model = self.solver.model
        if self.xpbd:
            return FusedCall(
                ("{fabric}({indices}, {rest_length}, {alpha_tilde}, {set_offsets}, cur)",),
                {"indices": model.constraint_indices, "rest_length": model.constraint_rest_length,
                 "alpha_tilde": self.alpha_tilde, "set_offsets": model.set_offsets},
                {"fabric": self.kernel},
            )
        return FusedCall(
            ("{fabric}({indices}, {rest_length}, {stiffness}, {set_offsets}, {phase_set_offsets}, {params}, cur)",),
            {"indices": model.constraint_indices, "rest_length": model.constraint_rest_length,
             "stiffness": model.constraint_stiffness, "set_offsets": model.set_offsets,
             "phase_set_offsets": model.phase_set_offsets, "params": self.params},
            {"fabric": self.kernel},
        )
