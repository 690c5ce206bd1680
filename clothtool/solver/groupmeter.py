"""Per-frame stats of the cloths of a merged group (clothtool.solver.merge), cheaply.

Each member's compiled stats call (frame_summary) gets its arguments ready-made (views of
the merged state and its own arrays; only 1/h changes), and its results become stats through
its own ClothMeter (``strain_from_spans``, ``summary_stats``): the same kernel on the same
arrays, so every member's stats are the numbers its own meter gives. (One compiled call for the whole group
would save ~5 us a cloth more, for ~0.9 s more compilation on a cold start.) Percentiles and face penetration are measured by each
member's own meter.
"""

from __future__ import annotations

from clothtool.solver.kernels.stats import frame_summary
from clothtool.solver.measure import PERCENTILE, ClothMeter


class GroupMeasure:
    """Every member's ``ClothMeter.measure(h, percentiles=False)``, measured together."""

    def __init__(self, group, meters: list[ClothMeter]):
        self.group = group
        self.meters = meters
        self._arguments = []  # per member: frame_summary's arguments before and after 1/h
        for meter in meters:
            model, state = meter.solver.model, meter.solver.state
            self._arguments.append((
                (model.constraint_indices, model.constraint_rest_length, meter.span_bounds, meter.groups, PERCENTILE,
                 state.cur, state.prev, model.mass),
                (model.tether_anchor, model.tether_rest_length, meter.span_max, meter.span_sum, meter.percentiles[:0]),
            ))
        self._token: tuple | None = None
        self._stats: list[dict] = []

    def stats(self, index: int, h: float) -> dict:
        """Member ``index``'s stats of the frame just simulated (all members are measured at
        once, when the group's frame or h changed since the last measure)."""
        token = (id(self.group.current_plan), h)
        if token != self._token:
            self._stats = [self._measure(k, 1.0 / h) for k in range(len(self.meters))]
            self._token = token
        return self._stats[index]

    def _measure(self, k: int, inv_h: float) -> dict:
        meter = self.meters[k]
        before, after = self._arguments[k]
        speed, energy, fastest, bad, stretch = frame_summary(*before, inv_h, *after)
        return meter.summary_stats(meter.strain_from_spans(), speed, energy, fastest, bad, stretch)


class MemberMeter:
    """A group member's meter: its plain stats measured with the group's, percentiles and
    face penetration from its own ClothMeter (the bake calls ``measure`` as on ClothMeter)."""

    def __init__(self, meter: ClothMeter, group: GroupMeasure, index: int):
        self.meter = meter
        self.group = group
        self.index = index

    def warm_up(self, percentiles: bool = True, mesh_penetration: bool = False, shape_penetration: bool = False) -> None:
        self.meter.warm_up(percentiles, mesh_penetration, shape_penetration)

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
