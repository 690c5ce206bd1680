"""Reference for clothtool.integrators.implicit.strain: Provot's strain limiting, from the
module docstring. Edges are visited colour by colour (edges of one colour share no particle,
so the order inside a colour does not matter); a sweep with no correction ends the loop."""

from __future__ import annotations

import numpy as np


def limit_strain(edges, rest_length, inv_mass, order, offsets, x0, h, limit, sweeps, v_mid, v_end):
    """Returns (v_mid, v_end, corrections) as new float64 arrays."""
    v_mid = np.array(v_mid, np.float64)
    v_end = np.array(v_end, np.float64)
    x0 = np.asarray(x0, np.float64)
    corrections = 0
    for _ in range(sweeps):
        changed = 0
        for color in range(len(offsets) - 1):
            for edge in order[offsets[color]:offsets[color + 1]]:
                i, j = edges[edge]
                wi, wj = inv_mass[i], inv_mass[j]
                if wi + wj == 0:
                    continue
                d = (x0[j] + h * v_mid[j]) - (x0[i] + h * v_mid[i])
                length = np.linalg.norm(d)
                longest = (1 + limit) * rest_length[edge]
                if length <= longest * (1 + 1e-9):  # the kernel's SLACK
                    continue
                # move the ends by (length - longest) along d, split by inverse mass, over h
                shift = (length - longest) / length * d / (wi + wj) / h
                for velocity in (v_mid, v_end):
                    velocity[i] += wi * shift
                    velocity[j] -= wj * shift
                changed += 1
        corrections += changed
        if changed == 0:
            break
    return v_mid, v_end, corrections
