"""Reference for clothtool.integrators.implicit.kernels.implicit_coloring: first-fit greedy
colouring in element order (each element takes the smallest colour that no earlier element
sharing one of its particles has)."""

from __future__ import annotations

import numpy as np


def greedy_colors(elements, particle_count):
    """Returns (colors (e,), colour count)."""
    used = [set() for _ in range(particle_count)]
    colors = np.empty(len(elements), np.int64)
    for e, element in enumerate(np.asarray(elements)):
        taken = set().union(*(used[p] for p in element))
        color = next(c for c in range(len(taken) + 1) if c not in taken)
        colors[e] = color
        for p in element:
            used[p].add(color)
    return colors, int(colors.max() + 1) if len(colors) else 0
