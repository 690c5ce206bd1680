"""TripletScheduler: split constraints into conflict-free sets (a colouring of mesh elements).

A *set* is a group of constraints in which no movable particle appears twice, so the
constraints of a set can be solved in any order, or in parallel, with the same result.
Pinned particles never move and so never conflict. The scheduler colours constraints
greedily in locality order (each constraint takes the smallest colour free at all of its
movable particles); the number of colours is bounded below by the largest number of
constraints meeting at one movable particle, which ``lower_bound`` reports.

The same scheduler orders virtual-particle triplets (three particles and a weight index)
into conflict-free batches of a given width, for solvers that process a batch at a time.

It lives with the mesh topology, below both the cook (constraint phases, virtual particles)
and the solver (the wind stage's triangle colours), which DESIGN.md keeps from importing
each other.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from clothtool._jit import kernel


@kernel
def _greedy_colors(elements, movable, words):
    """Colour of each row of ``elements`` (c,k) so that equal colours share no movable particle.

    ``used[p, w]`` is a bitmask of the colours already taken at particle p (64 per word).
    """
    c, k = elements.shape
    n = movable.shape[0]
    used = np.zeros((n, words), np.uint64)
    colors = np.empty(c, np.int32)
    full = np.uint64(0xFFFFFFFFFFFFFFFF)
    one = np.uint64(1)
    for e in range(c):
        color = -1
        for w in range(words):
            taken = np.uint64(0)
            for j in range(k):
                p = elements[e, j]
                if movable[p]:
                    taken |= used[p, w]
            if taken != full:
                bit = 0
                while (taken >> np.uint64(bit)) & one:
                    bit += 1
                color = w * 64 + bit
                break
        colors[e] = color
        word = color // 64
        mask = one << np.uint64(color % 64)
        for j in range(k):
            p = elements[e, j]
            if movable[p]:
                used[p, word] |= mask
    return colors


@dataclasses.dataclass(frozen=True)
class Schedule:
    """The result of scheduling: a permutation of the input rows and CSR set offsets."""

    order: np.ndarray  # i64 (c,) input row of each scheduled row
    offsets: np.ndarray  # i32 (s+1,) set (or batch) j owns scheduled rows [offsets[j], offsets[j+1])
    lower_bound: int  # largest number of rows meeting at one movable particle

    @property
    def set_count(self) -> int:
        return int(self.offsets.shape[0]) - 1


class TripletScheduler:
    """Schedules rows of particle indices (pairs, triplets, ...) into conflict-free groups.

    Args:
        elements: (c,k) particle indices, one row per constraint (or triplet).
        movable: bool (n,) False for pinned particles, which never conflict.
    """

    def __init__(self, elements: np.ndarray, movable: np.ndarray):
        self.elements = np.ascontiguousarray(elements, np.int64)
        self.movable = np.ascontiguousarray(movable, np.bool_)
        if self.elements.ndim != 2:
            raise ValueError("elements must be a (c,k) array")

    def lower_bound(self) -> int:
        """Largest number of rows that share one movable particle: no schedule has fewer sets."""
        used = self.elements.reshape(-1)
        used = used[self.movable[used]]
        return int(np.bincount(used).max()) if used.size else (1 if self.elements.shape[0] else 0)

    def _locality_order(self) -> np.ndarray:
        # Rows sorted by their smallest and then largest particle index: neighbouring rows
        # touch neighbouring memory, and greedy colouring of a grid in this order is optimal.
        if not self.elements.size:
            return np.zeros(0, np.intp)  # what lexsort gives for no rows
        # column by column: numpy's min(axis=1) over rows of 2-4 entries is ~10x slower
        columns = self.elements.T
        lo, hi = functools.reduce(np.minimum, columns), functools.reduce(np.maximum, columns)
        return np.lexsort((hi, lo))

    def _colors(self, order: np.ndarray, lower_bound: int) -> np.ndarray:
        k = max(self.elements.shape[1], 1)
        bound = max(lower_bound, 1)
        words = (k * bound) // 64 + 1  # greedy never needs more than k*(bound-1)+1 colours
        return _greedy_colors(self.elements[order], self.movable, words)

    def sets(self) -> Schedule:
        """Conflict-free sets of any size, few of them, each sorted for locality."""
        c = self.elements.shape[0]
        if c == 0:
            return Schedule(np.zeros(0, np.int64), np.zeros(1, np.int32), 0)
        order = self._locality_order()
        bound = self.lower_bound()
        colors = self._colors(order, bound)
        by_color = np.argsort(colors, kind="stable")
        counts = np.bincount(colors)
        offsets = np.zeros(counts.shape[0] + 1, np.int32)
        np.cumsum(counts, out=offsets[1:])
        return Schedule(order[by_color], offsets, bound)

    def batches(self, width: int) -> Schedule:
        """Conflict-free batches of at most ``width`` rows (the sets, cut into chunks)."""
        if width < 1:
            raise ValueError("batch width must be at least 1")
        schedule = self.sets()
        sizes = np.diff(schedule.offsets).astype(np.int64)
        chunks = -(-sizes // width)
        chunk_sizes = np.full(int(chunks.sum()), width, np.int64)
        last = np.cumsum(chunks) - 1
        chunk_sizes[last[chunks > 0]] = sizes[chunks > 0] - (chunks[chunks > 0] - 1) * width
        offsets = np.zeros(chunk_sizes.shape[0] + 1, np.int32)
        np.cumsum(chunk_sizes, out=offsets[1:])
        return Schedule(schedule.order, offsets, schedule.lower_bound)
