"""Per-frame stats of the cloths of a merged group (clothtool.solver.merge) in one compiled call.

A cloth's stats (clothtool.solver.measure.ClothMeter) cost one compiled call and a Python
reduction of its strain spans, ~40 us a cloth: for 16 small cloths more than their solve.
Here one call measures every member: it calls the very kernel ClothMeter calls
(``frame_summary``, unlinked through clothtool.solver.framecall, so the same machine code)
on each member's own rows and arrays, then reduces each member's spans per phase type as
``ClothMeter._strain_from_spans`` does (Python's ``max`` and a float64 running sum, in span
order), so every member's stats are the numbers its own meter gives. Percentiles and face
penetration are measured by each member's own meter.
"""

from __future__ import annotations

import numpy as np

from clothtool.solver.framecall import call_kernel
from clothtool.solver.kernels.stats import frame_summary
from clothtool.solver.measure import PHASE_LABELS, ClothMeter

_FIELDS = 5  # speed, energy, fastest, first non-finite, tether stretch


def _group_summary(indices, rest, spans, cur, prev, masses, inv_dt, anchors, tether_lengths, span_max, span_sum,
                   particles, constraints, span_rows, tethers, span_label, out, label_max, label_mean):
    """Member k: frame_summary over its rows particles[k]:particles[k+1] (and its constraint,
    span and tether rows); out[k] its five figures; label_max/label_mean[k, l] the strain of
    phase type l (PHASE_LABELS) reduced over its spans as ClothMeter does."""
    total = np.zeros(label_max.shape[1])
    count = np.zeros(label_max.shape[1], np.int64)
    for k in range(particles.shape[0] - 1):
        p0, p1 = particles[k], particles[k + 1]
        c0, c1 = constraints[k], constraints[k + 1]
        s0, s1 = span_rows[k], span_rows[k + 1]
        t0, t1 = tethers[k], tethers[k + 1]
        speed, energy, fastest, bad, stretch = call_kernel(frame_summary, (
            indices[c0:c1], rest[c0:c1], spans[s0:s1], cur[p0:p1], prev[p0:p1], masses[p0:p1], inv_dt,
            anchors[t0:t1], tether_lengths[t0:t1], span_max[s0:s1], span_sum[s0:s1],
        ))
        out[k, 0] = speed
        out[k, 1] = energy
        out[k, 2] = fastest
        out[k, 3] = bad
        out[k, 4] = stretch
        for label in range(label_max.shape[1]):
            label_max[k, label] = -np.inf
            total[label] = 0.0
            count[label] = 0
        for s in range(s0, s1):
            label = span_label[s]
            if span_max[s] > label_max[k, label]:  # max(worst, x) keeps worst unless x > worst
                label_max[k, label] = span_max[s]
            total[label] += span_sum[s]
            count[label] += spans[s, 1] - spans[s, 0]
        for label in range(label_max.shape[1]):
            label_mean[k, label] = total[label] / count[label] if count[label] > 0 else 0.0


_COMPILED: list = []


def _summary_function():
    """The group kernel, compiled in this process and never from the disk cache: it calls
    frame_summary unlinked, by the symbol this process compiled or loaded
    (clothtool.solver.framefn.compile_for says why a cached caller is unsafe)."""
    if not _COMPILED:
        import numba
        from numba.core.caching import NullCache

        function = numba.njit(nogil=True, error_model="numpy")(_group_summary)
        function._cache = NullCache()
        _COMPILED.append(function)
    return _COMPILED[0]


class GroupMeasure:
    """Every member's ``ClothMeter.measure(h, percentiles=False)`` from one compiled call."""

    def __init__(self, group, meters: list[ClothMeter]):
        self.group = group
        self.meters = meters
        models = [m.solver.model for m in meters]
        self.indices = np.ascontiguousarray(np.concatenate([m.constraint_indices for m in models]))
        self.rest = np.concatenate([m.constraint_rest_length for m in models])
        self.spans = np.ascontiguousarray(np.concatenate([m.span_bounds for m in meters]), np.int64).reshape(-1, 2)
        self.masses = np.concatenate([m.mass for m in models])
        self.anchors = np.concatenate([m.tether_anchor for m in models])
        self.tether_lengths = np.concatenate([m.tether_rest_length for m in models])
        self.span_max = np.zeros(self.spans.shape[0])
        self.span_sum = np.zeros(self.spans.shape[0])
        offsets = lambda sizes: np.cumsum([0] + sizes).astype(np.int64)  # noqa: E731
        self.particles = offsets([m.particle_count for m in models])
        self.constraints = offsets([m.constraint_indices.shape[0] for m in models])
        self.span_rows = offsets([m.span_bounds.shape[0] for m in meters])
        self.tethers = offsets([m.tether_anchor.shape[0] for m in models])
        self.span_label = np.array([PHASE_LABELS.index(label) for m in meters for label in m.span_labels], np.int64)
        self.out = np.zeros((len(meters), _FIELDS))
        self.label_max = np.zeros((len(meters), len(PHASE_LABELS)))
        self.label_mean = np.zeros((len(meters), len(PHASE_LABELS)))
        # per member: its phase types in the order its own meter reports them
        self.labels = [[(PHASE_LABELS.index(label), label) for label in dict.fromkeys(m.span_labels)] for m in meters]
        self._token: tuple | None = None
        self._stats: list[dict] = []

    def _arguments(self, h: float) -> tuple:
        state = self.group.state
        return (self.indices, self.rest, self.spans, state.cur, state.prev, self.masses, 1.0 / h, self.anchors,
                self.tether_lengths, self.span_max, self.span_sum, self.particles, self.constraints, self.span_rows,
                self.tethers, self.span_label, self.out, self.label_max, self.label_mean)

    def warm_up(self) -> None:
        """Compile the group kernel (after the members' meters compiled frame_summary)."""
        import numba

        function = _summary_function()
        types = tuple(numba.typeof(value) for value in self._arguments(1.0))
        if types not in function.overloads:
            function.compile(types)

    def stats(self, index: int, h: float) -> dict:
        """Member ``index``'s stats of the frame just simulated (all members measured at
        once, when the group's frame or h changed since the last measure)."""
        token = (id(self.group.current_plan), h)
        if token != self._token:
            _summary_function()(*self._arguments(h))
            self._token = token
            self._stats = self._dicts()
        return self._stats[index]

    def _dicts(self) -> list[dict]:
        rows = self.out.tolist()
        label_max, label_mean = self.label_max.tolist(), self.label_mean.tolist()
        result = []
        for k, meter in enumerate(self.meters):
            speed, energy, fastest, bad, stretch = rows[k]
            to_m = meter.solver.model.units_to_meters
            stats = {
                "strain": {label: {"max": label_max[k][l], "mean": label_mean[k][l]} for l, label in self.labels[k]},
                "max_speed": speed * to_m,
                "fastest_particle": int(fastest),
                "kinetic_energy": energy * to_m * to_m,
                "finite": bad < 0,
                "nonfinite_particle": int(bad),
            }
            if meter.has_tethers:
                stats["tether_stretch"] = stretch
            result.append(stats)
        return result


class MemberMeter:
    """A group member's meter: its plain stats from the group's one call, percentiles and
    face penetration from its own ClothMeter (the bake calls ``measure`` as on ClothMeter)."""

    def __init__(self, meter: ClothMeter, group: GroupMeasure, index: int):
        self.meter = meter
        self.group = group
        self.index = index

    def warm_up(self, percentiles: bool = True, mesh_penetration: bool = False) -> None:
        self.meter.warm_up(percentiles, mesh_penetration)  # without percentiles: frame_summary,
        if not percentiles and self.index == len(self.group.meters) - 1:  # which the group kernel calls
            self.group.warm_up()

    def measure(self, h: float, percentiles: bool, time: float | None = None) -> dict:
        if percentiles or (time is not None and self.meter.colliders is not None):
            return self.meter.measure(h, percentiles, time)
        return self.group.stats(self.index, h)


def make_meters(solvers: list) -> list:
    """A meter per cloth: a ClothMeter, or for the members of a merged group a MemberMeter."""
    meters: list = [ClothMeter(solver) for solver in solvers]
    groups: dict[int, list[int]] = {}
    for position, solver in enumerate(solvers):
        group = getattr(solver, "group", None)
        if group is not None:
            groups.setdefault(id(group), []).append(position)
    for positions in groups.values():
        measure = GroupMeasure(solvers[positions[0]].group, [meters[p] for p in positions])
        for index, p in enumerate(positions):
            meters[p] = MemberMeter(meters[p], measure, index)
    return meters
