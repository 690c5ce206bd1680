"""Per-frame measurements of one cloth: strain per phase type, tether stretch, speed, energy.

Speeds and kinetic energy are relative to the cloth's frame (the world for a cloth without
a track), in SI units (m/s, J).
"""

from __future__ import annotations

import numpy as np

from clothtool.solver.kernels.stats import constraint_strain, motion_summary, tether_stretch

PHASE_LABELS = ("vertical", "horizontal", "shearing", "bending")


class ClothMeter:
    def __init__(self, solver):
        self.solver = solver
        model = solver.model
        self.by_label = {label: model.phase_constraints(label) for label in PHASE_LABELS}
        self.by_label = {k: v for k, v in self.by_label.items() if v.size}
        self.strain = np.zeros(model.constraint_indices.shape[0], np.float32)
        self.has_tethers = model.has_tethers

    def warm_up(self) -> None:
        model, state = self.solver.model, self.solver.state
        constraint_strain(model.constraint_indices[:0], model.constraint_rest_length[:0], state.cur, self.strain[:0])
        motion_summary(state.cur[:0], state.prev[:0], model.mass[:0], 1.0)
        tether_stretch(model.tether_anchor[:0], model.tether_rest_length[:0], state.cur)

    def measure(self, h: float, percentiles: bool) -> dict:
        """Stats after the last iteration of a frame of iteration length ``h``."""
        model, state = self.solver.model, self.solver.state
        to_m = model.units_to_meters
        constraint_strain(model.constraint_indices, model.constraint_rest_length, state.cur, self.strain)
        strain = {}
        for label, indices in self.by_label.items():
            values = self.strain[indices]
            entry = {"max": float(values.max()), "mean": float(values.astype(np.float64).mean())}
            if percentiles:
                entry["p99"] = float(np.percentile(values, 99.0))
            strain[label] = entry
        speed, energy, fastest, bad = motion_summary(state.cur, state.prev, model.mass, 1.0 / h)
        stats = {
            "strain": strain,
            "max_speed": float(speed) * to_m,
            "fastest_particle": int(fastest),
            "kinetic_energy": float(energy) * to_m * to_m,
            "finite": bool(bad < 0),
            "nonfinite_particle": int(bad),
        }
        if self.has_tethers:
            stats["tether_stretch"] = float(tether_stretch(model.tether_anchor, model.tether_rest_length, state.cur))
        return stats
