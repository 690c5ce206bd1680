"""Per-frame measurements of one cloth: strain per phase type, tether stretch, speed, energy,
and how deep its faces sink into sphere and capsule colliders.

Speeds and kinetic energy are relative to the cloth's frame (the world for a cloth without
a track), in SI units (m/s, J). Face penetration (clothtool.solver.penetration) is measured
at the frame's end pose of the colliders, in metres, when the scene has colliders.
"""

from __future__ import annotations

import numpy as np

from clothtool.solver.kernels.stats import constraint_strain, motion_summary, strain_extremes, tether_stretch, upper_percentile
from clothtool.solver.penetration import face_penetration

PHASE_LABELS = ("vertical", "horizontal", "shearing", "bending")


class ClothMeter:
    def __init__(self, solver):
        self.solver = solver
        model = solver.model
        # each phase is a contiguous range of constraints: per label, its (first, last) spans
        self.spans: dict[str, list[tuple[int, int]]] = {}
        for p, label in enumerate(model.phase_labels):
            first = int(model.set_offsets[model.phase_set_offsets[p]])
            last = int(model.set_offsets[model.phase_set_offsets[p + 1]])
            if last > first:
                self.spans.setdefault(label, []).append((first, last))
        self.strain = np.zeros(model.constraint_indices.shape[0], solver.state.cur.dtype)
        self.has_tethers = model.has_tethers
        self.colliders = solver.environment.colliders

    def warm_up(self, percentiles: bool = True) -> None:
        """Compile the kernels ``measure(h, percentiles)`` calls (with percentiles: the
        strain-keeping ones, else the reducing one)."""
        model, state = self.solver.model, self.solver.state
        if percentiles:
            constraint_strain(model.constraint_indices[:0], model.constraint_rest_length[:0], state.cur, self.strain[:0])
            upper_percentile(self.strain[:0], 99.0)
        else:
            strain_extremes(model.constraint_indices[:0], model.constraint_rest_length[:0], state.cur)
        motion_summary(state.cur[:0], state.prev[:0], model.mass[:0], 1.0)
        if self.has_tethers:
            tether_stretch(model.tether_anchor[:0], model.tether_rest_length[:0], state.cur)

    def measure(self, h: float, percentiles: bool, time: float | None = None) -> dict:
        """Stats after the last iteration of a frame of iteration length ``h`` ending at
        ``time`` (seconds; face penetration is measured when given and there are colliders)."""
        model, state = self.solver.model, self.solver.state
        to_m = model.units_to_meters
        indices, rest = model.constraint_indices, model.constraint_rest_length
        strain = {}
        for label in PHASE_LABELS:
            if label not in self.spans:
                continue
            spans = self.spans[label]
            if percentiles:  # the 99th percentile needs every strain: compute and keep them
                for first, last in spans:
                    constraint_strain(indices[first:last], rest[first:last], state.cur, self.strain[first:last])
                values = self.strain[spans[0][0] : spans[0][1]] if len(spans) == 1 else np.concatenate(
                    [self.strain[a:b] for a, b in spans]
                )
                strain[label] = {
                    "max": float(values.max()),
                    "mean": float(values.sum(dtype=np.float64)) / values.size,
                    "p99": float(upper_percentile(values, 99.0)),
                }
                continue
            worst, total, count = -np.inf, 0.0, 0
            for first, last in spans:
                span_max, span_sum = strain_extremes(indices[first:last], rest[first:last], state.cur)
                worst, total, count = max(worst, span_max), total + span_sum, count + last - first
            strain[label] = {"max": float(worst), "mean": total / count}
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
        if time is not None and self.colliders is not None:
            faces = face_penetration(
                self.solver.world_points(), model.triangles, self.colliders(time), to_m, float(model.material.thickness)
            )
            stats["max_penetration"] = max(faces.depth, 0.0)
            stats["faces_beyond_thickness"] = faces.faces_beyond
        return stats
