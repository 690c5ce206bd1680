"""Per-frame measurements of one cloth: strain per phase type, tether stretch, speed, energy,
and how deep its faces sink into sphere and capsule colliders.

Speeds and kinetic energy are relative to the cloth's frame (the world for a cloth without
a track), in SI units (m/s, J). Face penetration (clothtool.solver.penetration) is measured
at the frame's end pose of the colliders, in metres, when the scene has colliders.
"""

from __future__ import annotations

import numpy as np

from clothtool.solver.kernels.stats import constraint_strain, frame_summary, motion_summary, tether_stretch, upper_percentile
from clothtool.solver.penetration import face_penetration, warm_up_mesh_depths, warm_up_round_cone_depths

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
        # frame_summary's spans, label by label in PHASE_LABELS order, and its outputs
        ordered = [(label, span) for label in PHASE_LABELS for span in self.spans.get(label, ())]
        self.span_labels = [label for label, _ in ordered]
        self.span_bounds = np.array([span for _, span in ordered], np.int64).reshape(-1, 2)
        self.span_max = np.zeros(len(ordered))
        self.span_sum = np.zeros(len(ordered))
        self._span_counts = (self.span_bounds[:, 1] - self.span_bounds[:, 0]).tolist()
        self._span_per_label = len(set(self.span_labels)) == len(self.span_labels)
        self.has_tethers = model.has_tethers
        self.colliders = solver.environment.colliders

    def warm_up(self, percentiles: bool = True, mesh_penetration: bool = False, shape_penetration: bool = False) -> None:
        """Compile the kernels ``measure(h, percentiles)`` calls (with percentiles: the
        strain-keeping ones, else the reducing one; with mesh_penetration and
        shape_penetration, the measure of faces in mesh colliders and in spheres and capsules)."""
        model, state = self.solver.model, self.solver.state
        if mesh_penetration:
            warm_up_mesh_depths()
        if shape_penetration:
            warm_up_round_cone_depths()
        if percentiles:
            constraint_strain(model.constraint_indices[:0], model.constraint_rest_length[:0], state.cur, self.strain[:0])
            upper_percentile(self.strain[:0], 99.0)
            motion_summary(state.cur[:0], state.prev[:0], model.mass[:0], 1.0)
            if self.has_tethers:
                tether_stretch(model.tether_anchor[:0], model.tether_rest_length[:0], state.cur)
        else:
            frame_summary(model.constraint_indices, model.constraint_rest_length, self.span_bounds[:0], state.cur[:0],
                          state.prev[:0], model.mass[:0], 1.0, model.tether_anchor[:0], model.tether_rest_length[:0],
                          self.span_max, self.span_sum)

    def measure(self, h: float, percentiles: bool, time: float | None = None) -> dict:
        """Stats after the last iteration of a frame of iteration length ``h`` ending at
        ``time`` (seconds; face penetration is measured when given and there are colliders).
        Without percentiles one compiled call (frame_summary) measures everything."""
        model, state = self.solver.model, self.solver.state
        to_m = model.units_to_meters
        if percentiles:
            strain = self._strain_with_percentiles()
            speed, energy, fastest, bad = motion_summary(state.cur, state.prev, model.mass, 1.0 / h)
            stretch = tether_stretch(model.tether_anchor, model.tether_rest_length, state.cur) if self.has_tethers else 0.0
        else:
            speed, energy, fastest, bad, stretch = frame_summary(
                model.constraint_indices, model.constraint_rest_length, self.span_bounds, state.cur, state.prev,
                model.mass, 1.0 / h, model.tether_anchor, model.tether_rest_length, self.span_max, self.span_sum,
            )
            strain = self.strain_from_spans()
        stats = self.summary_stats(strain, speed, energy, fastest, bad, stretch)
        if time is not None and self.colliders is not None:
            faces = face_penetration(
                self.solver.world_points(), model.triangles, self.colliders(time), to_m, float(model.material.thickness)
            )
            stats["max_penetration"] = max(faces.depth, 0.0)
            stats["faces_beyond_thickness"] = faces.faces_beyond
        return stats

    def summary_stats(self, strain: dict, speed, energy, fastest, bad, stretch) -> dict:
        """The frame's stats dict from the strain per phase type and frame_summary's (or
        motion_summary's and tether_stretch's) results, in SI units."""
        to_m = self.solver.model.units_to_meters
        stats = {
            "strain": strain,
            "max_speed": float(speed) * to_m,
            "fastest_particle": int(fastest),
            "kinetic_energy": float(energy) * to_m * to_m,
            "finite": bool(bad < 0),
            "nonfinite_particle": int(bad),
        }
        if self.has_tethers:
            stats["tether_stretch"] = float(stretch)
        return stats

    def strain_from_spans(self) -> dict:
        """Per phase type (max, mean) from frame_summary's per-span extremes (over plain
        lists: numpy scalars cost ~30 us a frame here, more than a small cloth's solve)."""
        spans = zip(self.span_labels, self.span_max.tolist(), self.span_sum.tolist(), self._span_counts)
        if self._span_per_label:  # an untiled fabric: each phase type one span
            return {label: {"max": high, "mean": total / count} for label, high, total, count in spans}
        worst: dict[str, float] = {}
        totals: dict[str, list] = {}  # label -> [sum, count]
        for label, high, total, count in spans:
            worst[label] = max(worst.get(label, -np.inf), high)
            entry = totals.setdefault(label, [0.0, 0])
            entry[0] += total
            entry[1] += count
        return {label: {"max": worst[label], "mean": totals[label][0] / totals[label][1]} for label in worst}

    def _strain_with_percentiles(self) -> dict:
        """Per phase type (max, mean, p99): the 99th percentile needs every strain, so they
        are computed and kept."""
        model, state = self.solver.model, self.solver.state
        indices, rest = model.constraint_indices, model.constraint_rest_length
        strain = {}
        for label in PHASE_LABELS:
            if label not in self.spans:
                continue
            spans = self.spans[label]
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
        return strain
