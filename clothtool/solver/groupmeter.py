"""Per-frame stats of the cloths of a merged group (clothtool.solver.merge), in one call.

One compiled stats call (frame_summary, whose members are the group's cloths) measures every
member on the merged state: the members' constraint, tether and mass arrays concatenated
(their indices count from each member's first particle, as when measured alone), and each
member's meter reading its figures from views of the call's outputs (``span_max``,
``span_sum``, ``percentiles``), so every member's stats are the numbers its own meter gives,
to the bit. One call instead of one per cloth (16 cloths of 16^2: 18 compiled calls a frame
became 3), percentiles included.
"""

from __future__ import annotations

import numpy as np

from clothtool.solver.kernels.stats import frame_summary
from clothtool.solver.measure import PERCENTILE, ClothMeter, motion_figures


def _offsets(counts) -> np.ndarray:
    return np.cumsum([0, *counts]).astype(np.int64)


class GroupMeasure:
    """Every member's ``ClothMeter.measure(h, percentiles)``, measured together."""

    def __init__(self, group, meters: list[ClothMeter]):
        self.group = group
        self.meters = meters
        # frame_summary's members in the group's order: member k owns rows group.offsets[k] ..
        # group.offsets[k + 1] of the merged state
        self._order = sorted(range(len(meters)), key=lambda k: meters[k].solver.index)
        ordered = [meters[k] for k in self._order]
        models = [meter.solver.model for meter in ordered]
        constraint_base = _offsets(m.constraint_indices.shape[0] for m in models)
        span_base = _offsets(meter.span_bounds.shape[0] for meter in ordered)
        group_base = _offsets(len(meter.group_labels) for meter in ordered)
        spans = np.concatenate([meter.span_bounds + constraint_base[k] for k, meter in enumerate(ordered)])
        groups = np.concatenate([meter.groups[:-1] + span_base[k] for k, meter in enumerate(ordered)] + [span_base[-1:]])
        self.span_max, self.span_sum = np.zeros(span_base[-1]), np.zeros(span_base[-1])
        self.percentiles = np.zeros(group_base[-1])
        for k, meter in enumerate(ordered):  # each meter reads (and its own measure writes) the group's outputs
            meter.span_max = self.span_max[span_base[k] : span_base[k + 1]]
            meter.span_sum = self.span_sum[span_base[k] : span_base[k + 1]]
            meter.percentiles = self.percentiles[group_base[k] : group_base[k + 1]]
        self.motion = np.zeros((len(meters), 5))
        self._before = (
            np.concatenate([m.constraint_indices for m in models]), np.concatenate([m.constraint_rest_length for m in models]),
            spans, groups, group_base, np.asarray(group.offsets, np.int64), _offsets(m.tether_anchor.shape[0] for m in models),
            PERCENTILE, group.state.cur, group.state.prev, np.concatenate([m.mass for m in models]),
        )
        self._after = (
            np.concatenate([m.tether_anchor for m in models]), np.concatenate([m.tether_rest_length for m in models]),
            self.span_max, self.span_sum,
        )
        self._token: tuple | None = None
        self._stats: list[dict] = []

    def stats(self, index: int, h: float, percentiles: bool) -> dict:
        """Member ``index``'s stats of the frame just simulated (all members are measured at
        once, when the group's frame, h or the percentiles asked for changed since the last
        measure)."""
        token = (id(self.group.current_plan), h, percentiles)
        if token != self._token:
            frame_summary(*self._before, 1.0 / h, *self._after, self.percentiles if percentiles else self.percentiles[:0],
                          self.motion)
            rows = self.motion.tolist()
            self._stats = [{}] * len(self.meters)
            for row, k in zip(rows, self._order):
                self._stats[k] = self.meters[k].frame_stats(motion_figures(row), percentiles)
            self._token = token
        return self._stats[index]


class MemberMeter:
    """A group member's meter: its stats measured with the group's, face penetration (should
    a merged cloth have colliders) by its own ClothMeter (the bake calls ``measure`` as on
    ClothMeter)."""

    def __init__(self, meter: ClothMeter, group: GroupMeasure, index: int):
        self.meter = meter
        self.group = group
        self.index = index

    def warm_up(self, percentiles: bool = True, mesh_penetration: bool = False, shape_penetration: bool = False) -> None:
        self.meter.warm_up(percentiles, mesh_penetration, shape_penetration)

    def measure(self, h: float, percentiles: bool, time: float | None = None) -> dict:
        if time is not None and self.meter.colliders is not None:
            return self.meter.measure(h, percentiles, time)
        return self.group.stats(self.index, h, percentiles)


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
