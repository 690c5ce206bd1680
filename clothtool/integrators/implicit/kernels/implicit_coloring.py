"""Greedy colouring of elements (triangles, hinges, edges) into groups that share no particle,
so that each group can be assembled in parallel without write conflicts."""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel


@kernel
def greedy_colors(elements, particle_count, colors):
    """colors (e,) out: the smallest colour not used by an earlier element sharing a particle.
    Returns the number of colours."""
    corners = elements.shape[1]
    # per particle, a bit mask of the colours of the elements seen so far (<= 64 colours
    # in each round; rounds handle meshes whose valence needs more)
    used = np.zeros(particle_count, np.uint64)
    uncolored = elements.shape[0]
    for e in range(elements.shape[0]):
        colors[e] = -1
    base = 0
    while uncolored > 0:
        for p in range(particle_count):
            used[p] = np.uint64(0)
        for e in range(elements.shape[0]):
            if colors[e] >= 0:
                continue
            mask = np.uint64(0)
            for c in range(corners):
                mask |= used[elements[e, c]]
            if mask == np.uint64(0xFFFFFFFFFFFFFFFF):
                continue
            bit = 0
            while (mask >> np.uint64(bit)) & np.uint64(1):
                bit += 1
            colors[e] = base + bit
            uncolored -= 1
            flag = np.uint64(1) << np.uint64(bit)
            for c in range(corners):
                used[elements[e, c]] |= flag
        base += 64
    count = 0
    for e in range(elements.shape[0]):
        count = max(count, colors[e] + 1)
    return count
