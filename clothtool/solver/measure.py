"""Per-frame measurements of one cloth: strain per phase type, tether stretch, speed, energy,
and how deep its faces sink into sphere and capsule colliders.

Speeds and kinetic energy are relative to the cloth's frame (the world for a cloth without
a track), in SI units (m/s, J). Face penetration (clothtool.solver.penetration) is measured
at the frame's end pose of the colliders, in metres, when the scene has colliders.
"""

from __future__ import annotations

import numpy as np

from clothtool.solver.kernels.stats import frame_summary
from clothtool.solver.penetration import ConeRecords, face_penetration, warm_up_mesh_depths, warm_up_round_cone_depths

PHASE_LABELS = ("vertical", "horizontal", "shearing", "bending")
PERCENTILE = 99.0  # the report's upper strain percentile, "p99"


def motion_figures(row: list) -> tuple:
    """frame_summary's motion row as (max speed, kinetic energy, fastest particle, first
    non-finite particle, tether stretch)."""
    speed, energy, fastest, bad, stretch = row
    return speed, energy, int(fastest), int(bad), stretch


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
        # frame_summary's spans, label by label in PHASE_LABELS order, its groups (a label's
        # spans: groups[g] .. groups[g + 1]) and its outputs
        ordered = [(label, span) for label in PHASE_LABELS for span in self.spans.get(label, ())]
        self.span_labels = [label for label, _ in ordered]
        self.span_bounds = np.array([span for _, span in ordered], np.int64).reshape(-1, 2)
        self.span_max = np.zeros(len(ordered))
        self.span_sum = np.zeros(len(ordered))
        self.group_labels = [label for label in PHASE_LABELS if label in self.spans]
        self.groups = np.cumsum([0] + [len(self.spans[label]) for label in self.group_labels]).astype(np.int64)
        self.percentiles = np.zeros(len(self.group_labels))  # p99 strain per label, when asked for
        self._no_percentiles = self.percentiles[:0]
        # frame_summary's one member: every particle, tether and group
        self.members = np.array([0, len(self.group_labels)], np.int64)
        self.particles = np.array([0, model.particle_count], np.int64)
        self.tethers = np.array([0, model.tether_anchor.shape[0]], np.int64)
        self.motion = np.zeros((1, 5))  # max speed, kinetic energy, fastest, first non-finite, tether stretch
        self._span_counts = (self.span_bounds[:, 1] - self.span_bounds[:, 0]).tolist()
        self._span_per_label = len(set(self.span_labels)) == len(self.span_labels)
        self.has_tethers = model.has_tethers
        self.colliders = solver.environment.colliders
        self.cones = ConeRecords()  # the colliders' round cones, kept from frame to frame

    def warm_up(self, percentiles: bool = True, mesh_penetration: bool = False, shape_penetration: bool = False) -> None:
        """Compile the kernels ``measure`` calls (with mesh_penetration and shape_penetration, the
        measure of faces in mesh colliders and in spheres and capsules): one kernel (the same
        compilation with and without percentiles) measures, here once on the current state."""
        if mesh_penetration:
            warm_up_mesh_depths()
        if shape_penetration:
            warm_up_round_cone_depths()
        self.summarise(1.0, percentiles)

    def summarise(self, inv_h: float, percentiles: bool) -> tuple:
        """frame_summary over this cloth (strain extremes per span into span_max and span_sum,
        with percentiles the p99 strain per label into ``percentiles``); returns its (max
        speed, kinetic energy, fastest particle, first non-finite particle, tether stretch)."""
        model, state = self.solver.model, self.solver.state
        frame_summary(
            model.constraint_indices, model.constraint_rest_length, self.span_bounds, self.groups, self.members,
            self.particles, self.tethers, PERCENTILE, state.cur, state.prev, model.mass, inv_h, model.tether_anchor,
            model.tether_rest_length, self.span_max, self.span_sum, self.percentiles if percentiles else self._no_percentiles,
            self.motion,
        )
        return motion_figures(self.motion[0].tolist())

    def measure(self, h: float, percentiles: bool, time: float | None = None) -> dict:
        """Stats after the last iteration of a frame of iteration length ``h`` ending at
        ``time`` (seconds; face penetration is measured when given and there are colliders),
        in one compiled call (frame_summary); with percentiles the strain per phase type
        carries its 99th percentile too."""
        model = self.solver.model
        stats = self.frame_stats(self.summarise(1.0 / h, percentiles), percentiles)
        if time is not None and self.colliders is not None:
            faces = face_penetration(
                self.solver.world_points(), model.triangles, self.colliders(time), model.units_to_meters,
                float(model.material.thickness), self.cones,
            )
            stats["max_penetration"] = max(faces.depth, 0.0)
            stats["faces_beyond_thickness"] = faces.faces_beyond
        return stats

    def frame_stats(self, motion: tuple, percentiles: bool) -> dict:
        """The stats dict from frame_summary's figures: its motion figures (motion_figures)
        and what it left in span_max, span_sum and, with percentiles, ``percentiles``."""
        strain = self.strain_from_spans()
        if percentiles:
            for label, p99 in zip(self.group_labels, self.percentiles.tolist()):
                strain[label]["p99"] = p99
        return self.summary_stats(strain, *motion)

    def summary_stats(self, strain: dict, speed, energy, fastest, bad, stretch) -> dict:
        """The frame's stats dict from the strain per phase type and frame_summary's motion
        figures (motion_figures), in SI units."""
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
