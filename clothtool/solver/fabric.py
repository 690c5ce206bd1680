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

from clothtool.solver.fabric_layers import phase_layers
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


# The fabric's line in the frame function (clothtool.solver.framefn) and its argument names.
_FUSED_NAMES = ("indices", "rest_length", "per_constraint", "set_offsets", "phase_set_offsets", "params",
                "layer_group_offsets", "group_phase_offsets")
_FUSED_LINES = ("{fabric}(" + ", ".join("{%s}" % name for name in _FUSED_NAMES) + ", cur)",)

class FabricStage(Stage):
    name = "fabric"

    def __init__(self, solver):
        super().__init__(solver)
        model = solver.model
        # Phases that share no particle run on the cores at once (a big cloth's cache tiles)
        self.layer_group_offsets, self.group_phase_offsets = phase_layers(
            model.constraint_indices, model.set_offsets, model.phase_set_offsets)
        # thread start-up costs more than it saves on little work; results are identical. The
        # work the cores share is a set of a one-group layer or a layer of several groups.
        set_sizes = np.diff(model.set_offsets)
        layer_sizes = np.diff(model.set_offsets[model.phase_set_offsets[self.group_phase_offsets[self.layer_group_offsets]]])
        several = np.diff(self.layer_group_offsets) > 1
        largest = max(int(set_sizes.max(initial=0)), int(layer_sizes[several].max(initial=0)))
        big = largest >= solver.config.fabric_parallel_threshold
        self.xpbd = solver.config.stiffness_mode == "xpbd"
        # per phase (stiffness, multiplier, compression term, stretch term); unused by xpbd
        self.params = np.zeros((len(model.phase_labels), 4), np.float32)
        if self.xpbd:
            self.kernel = solve_xpbd_parallel if big else solve_xpbd
            # float32 max stands in for an infinite compliance (a constraint with no stiffness)
            self.compliance = np.minimum(constraint_compliance(model), np.finfo(np.float32).max)
            self.per_constraint = self.alpha_tilde = np.zeros(model.constraint_indices.shape[0], np.float32)
        else:
            self.kernel = solve_phases_parallel if big else solve_phases
            self.per_constraint = model.constraint_stiffness
        self.params_h = None  # the iteration length the parameters were converted for
        self._fused: FusedCall | None = None  # see fused_call

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
        by_label: dict[str, tuple] = {}  # a tiled fabric repeats each phase type once per tile
        for p, label in enumerate(self.solver.model.phase_labels):
            if label not in by_label:
                phase = material.phase(label)
                by_label[label] = (
                    iteration_stiffness(phase.stiffness, f, plan.h),
                    iteration_multiplier(phase.stiffness_multiplier, f, plan.h),
                    limit_term(phase.compression_limit),
                    limit_term(phase.stretch_limit),
                )
            self.params[p] = by_label[label]

    def _arguments(self, phases: slice = slice(None)) -> tuple:
        model = self.solver.model
        layers = self.layer_group_offsets if phases.stop is None else self.layer_group_offsets[:1]
        return (model.constraint_indices, model.constraint_rest_length, self.per_constraint, model.set_offsets,
                model.phase_set_offsets, self.params[phases], layers, self.group_phase_offsets)

    def warm_up(self) -> None:
        self.kernel(*self._arguments(slice(0)), self.solver.state.cur)  # no layers: compiles, solves nothing

    def run(self, iteration: Iteration) -> None:
        self.kernel(*self._arguments(), self.solver.state.cur)

    def fused_call(self) -> FusedCall:
        # the same arrays every frame (begin_frame converts the parameters in place): built once
        fused = self._fused
        if fused is None or fused.kernels["fabric"] is not self.kernel:
            fused = self._fused = FusedCall(_FUSED_LINES, dict(zip(_FUSED_NAMES, self._arguments())), {"fabric": self.kernel})
        return fused
