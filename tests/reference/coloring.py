"""Reference for clothtool.mesh.coloring (the scheduler's greedy colouring kernel)."""

from __future__ import annotations

import numpy as np


def _greedy_colors(elements, movable, words):
    """Rows in order; each takes the smallest colour not yet taken at any of its movable
    particles, so rows of one colour share no movable particle (pinned ones never conflict).

    ``words`` only sizes the kernel's bitmask (64 colours a word); the scheduler passes
    enough for any greedy colouring, so the reference needs no limit.
    """
    elements = np.asarray(elements, np.int64)
    movable = np.asarray(movable, bool)
    taken: dict[int, set[int]] = {}
    colors = np.empty(elements.shape[0], np.int32)
    for row, particles in enumerate(elements.tolist()):
        moving = [p for p in particles if movable[p]]
        busy = set().union(*(taken.get(p, set()) for p in moving))
        color = next(c for c in range(len(busy) + 1) if c not in busy)
        colors[row] = color
        for p in moving:
            taken.setdefault(p, set()).add(color)
    return colors
