"""Strain limiting (Provot 1995; Bridson, Marino & Fedkiw 2003): a safety net after the solve.

One linearised backward-Euler step per frame cannot rotate an edge far: motion across an
edge costs nothing to first order, so where neighbours move apart sideways (a cloth released
flat from two pins, a particle stopped by a collider while its neighbour falls on) a single
step can stretch an edge by tens of percent, and the next step's huge forces overshoot.
After the solve, every edge of the triangles that ends the step longer than (1 + limit)
times its rest length is shortened to that length, both ends moving in proportion to their
inverse masses (pinned ends do not move), with a few Gauss-Seidel sweeps over conflict-free
edge colours. The correction moves the step's average velocity (the new position is
x0 + h v) and the kept velocity alike, as Provot corrects velocities.

Edges within the limit are untouched, so for cloth that the solve keeps below it (the normal
case once it hangs) this stage does nothing.
"""

from __future__ import annotations

import math

from numba import prange
from numba.extending import register_jitable as jitable

from clothtool._jit import kernel

SLACK = 1e-9  # relative: an edge at the limit but for rounding is left alone


@jitable
def _move(v_mid, v_end, i, s, d0, d1, d2):
    v_mid[i, 0] += s * d0
    v_mid[i, 1] += s * d1
    v_mid[i, 2] += s * d2
    v_end[i, 0] += s * d0
    v_end[i, 1] += s * d1
    v_end[i, 2] += s * d2


@kernel(parallel=True)
def limit_strain(edges, rest_length, inv_mass, order, offsets, x0, h, limit, sweeps, v_mid, v_end):
    """Shorten the edges whose end positions x0 + h v_mid are longer than (1 + limit) rest
    lengths (by more than the relative SLACK); ``sweeps`` Gauss-Seidel passes over the colours (order, offsets). Updates
    v_mid and v_end (n,3) by the same velocity corrections. Returns how many edge
    corrections were made."""
    corrections = 0
    for _ in range(sweeps):
        changed = 0
        for color in range(offsets.shape[0] - 1):
            for e in prange(offsets[color], offsets[color + 1]):
                edge = order[e]
                i = edges[edge, 0]
                j = edges[edge, 1]
                wi = inv_mass[i]
                wj = inv_mass[j]
                if wi + wj == 0.0:
                    continue
                d0 = (x0[j, 0] + h * v_mid[j, 0]) - (x0[i, 0] + h * v_mid[i, 0])
                d1 = (x0[j, 1] + h * v_mid[j, 1]) - (x0[i, 1] + h * v_mid[i, 1])
                d2 = (x0[j, 2] + h * v_mid[j, 2]) - (x0[i, 2] + h * v_mid[i, 2])
                length = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                longest = (1.0 + limit) * rest_length[edge]
                if length <= longest * (1.0 + SLACK):
                    continue
                # velocity change that removes the excess length over the step
                s = (length - longest) / (length * h * (wi + wj))
                _move(v_mid, v_end, i, s * wi, d0, d1, d2)
                _move(v_mid, v_end, j, -s * wj, d0, d1, d2)
                changed += 1
        corrections += changed
        if changed == 0:
            break
    return corrections
