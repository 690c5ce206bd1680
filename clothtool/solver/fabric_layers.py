"""Which of a fabric's phases may be solved at the same time, from the particles they touch.

The fabric's order is the solve order: phases one after another, each phase's sets one
after another. A big cloth's phases come tile by tile (clothtool.cook.tiles), and the
phases of two tiles that share no particle can be solved by two cores at once with the
bits of the serial order, as neither reads what the other writes. This module finds such
phases without trusting the cook: it groups consecutive phases into *groups* and
consecutive groups into *layers* so that

* the groups of one layer touch pairwise disjoint particle index ranges, and
* a group's phases (and their sets) stay in their order.

Solving the layers in order, each layer's groups in any order or at once, is then the
serial order with only independent work exchanged: the same bits. A phase joins the last
group when its particle range meets that group's and none of the layer's other groups';
it starts a new group in the layer when it meets none of them; otherwise it starts a new
layer. A fabric cooked untiled (every phase spans the cloth) gets one layer per phase,
whose sets the kernel runs on the cores block by block instead.
"""

from __future__ import annotations

import numpy as np


def phase_ranges(constraint_indices: np.ndarray, set_offsets: np.ndarray, phase_set_offsets: np.ndarray):
    """i64 (p,), (p,): the lowest and highest particle of each phase's constraints
    (lowest > highest for a phase with none)."""
    first = set_offsets[phase_set_offsets[:-1]].astype(np.int64)
    last = set_offsets[phase_set_offsets[1:]].astype(np.int64)
    phases = first.shape[0]
    lowest = np.full(phases, np.iinfo(np.int64).max, np.int64)
    highest = np.full(phases, -1, np.int64)
    nonempty = np.flatnonzero(last > first)
    if nonempty.size:
        # two columns compared whole: min(axis=1) reduces each 2-element row on its own, 10x slower
        row_lo = np.minimum(constraint_indices[:, 0], constraint_indices[:, 1]).astype(np.int64)
        row_hi = np.maximum(constraint_indices[:, 0], constraint_indices[:, 1]).astype(np.int64)
        # Phases own consecutive constraint ranges that cover them all (the sets' CSR), so each
        # nonempty phase's reduction runs exactly to the next nonempty phase's start.
        lowest[nonempty] = np.minimum.reduceat(row_lo, first[nonempty])
        highest[nonempty] = np.maximum.reduceat(row_hi, first[nonempty])
    return lowest, highest


def phase_layers(constraint_indices: np.ndarray, set_offsets: np.ndarray, phase_set_offsets: np.ndarray):
    """(layer_group_offsets, group_phase_offsets), i64 CSR arrays: layer l owns groups
    [layer_group_offsets[l], layer_group_offsets[l+1]), group g owns phases
    [group_phase_offsets[g], group_phase_offsets[g+1]) (see the module docs)."""
    lowest, highest = phase_ranges(constraint_indices, set_offsets, phase_set_offsets)
    layer_group_offsets, group_phase_offsets = [0], [0]
    last_lo = last_hi = 0  # the last group's particle range
    others_lo, others_hi = np.iinfo(np.int64).max, -1  # the hull of the layer's other groups
    for p, (lo, hi) in enumerate(zip(lowest.tolist(), highest.tolist())):
        if p == 0:
            last_lo, last_hi = lo, hi
        elif lo > hi:  # no constraints: nothing to order, stays with the last group
            pass
        else:
            meets_others = lo <= others_hi and others_lo <= hi
            meets_last = lo <= last_hi and last_lo <= hi
            if meets_last and not meets_others:
                last_lo, last_hi = min(last_lo, lo), max(last_hi, hi)
            elif not meets_last and not meets_others:
                group_phase_offsets.append(p)
                others_lo, others_hi = min(others_lo, last_lo), max(others_hi, last_hi)
                last_lo, last_hi = lo, hi
            else:
                group_phase_offsets.append(p)
                layer_group_offsets.append(len(group_phase_offsets) - 1)
                others_lo, others_hi = np.iinfo(np.int64).max, -1
                last_lo, last_hi = lo, hi
    phases = lowest.shape[0]
    if phases:
        group_phase_offsets.append(phases)
        layer_group_offsets.append(len(group_phase_offsets) - 1)
    return np.asarray(layer_group_offsets, np.int64), np.asarray(group_phase_offsets, np.int64)
