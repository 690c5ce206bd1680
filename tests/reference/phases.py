"""Reference for clothtool.cook.phases (the bending-pair kernel)."""

from __future__ import annotations

import numpy as np


def _bending_pairs(neighbor_offsets, neighbors, pos, cos_limit):
    """(m,2) pairs (min(i,k), max(i,k)), grouped by middle particle j in order and, within j,
    by the position of i in j's neighbour list, where

    * j's neighbour k is the most opposite to i: the smallest cosine between the unit
      directions j->i and j->k over j's other neighbours (the first one on a tie),
    * and i is likewise the most opposite to k (the pairing is mutual, so each pair once),
    * and that cosine is below ``cos_limit`` (the angle i-j-k exceeds the bending limit).

    A neighbour at j's own position has no direction (a zero vector, cosine 0 with all).
    """
    offsets = np.asarray(neighbor_offsets, np.int64)
    neighbors = np.asarray(neighbors, np.int64)
    pos = np.asarray(pos, np.float64)
    out = []
    for j in range(offsets.shape[0] - 1):
        ring = neighbors[offsets[j] : offsets[j + 1]]
        if ring.size < 2:
            continue
        d = pos[ring] - pos[j]
        # the three products summed x, y, z in that order: equal cosines compare equal, so
        # "first on a tie" does not depend on how a matrix product would round
        length = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])
        u = d / np.maximum(length, 1e-300)[:, None]
        cos = u[:, None, 0] * u[None, :, 0] + u[:, None, 1] * u[None, :, 1] + u[:, None, 2] * u[None, :, 2]
        np.fill_diagonal(cos, np.inf)
        best = np.argmin(cos, axis=1)
        best_cos = cos[np.arange(ring.size), best]
        for a in range(ring.size):
            b = best[a]
            if b > a and best[b] == a and best_cos[a] < cos_limit:
                out.append((min(ring[a], ring[b]), max(ring[a], ring[b])))
    return np.array(out, np.int64).reshape(-1, 2)
