"""Reference for clothtool.solver.kernels.constraints: the seed's "Distance constraints"
(constrainMotion), "Separation constraints" and "Tether constraints", vectorised.

Each particle's correction depends only on its own position and sphere (and, for tethers, on
anchors, which are pinned and never move), so all particles can be corrected at once.
"""

from __future__ import annotations

import numpy as np

# the kernels guard coincident particles with a tiny epsilon (see kernels/constraints.py)
DISTANCE_EPSILON = 1e-30


def constrain_motion(centers, radii, scale, bias, stiffness, cur):
    """Seed: delta = c - p; slack = 1 - max(0, r*scale + bias) / sqrt(eps + |delta|^2); where
    slack > 0 the particle moves by delta * slack * stiffness, and a radius <= 0 zeroes cur.w.
    Returns cur as a float64 copy."""
    cur = np.array(cur, np.float64)
    delta = np.asarray(centers, np.float64)[:, :3] - cur[:, :3]
    sqr_length = DISTANCE_EPSILON + np.einsum("ij,ij->i", delta, delta)
    radius = np.maximum(0.0, np.asarray(radii, np.float64) * float(scale) + float(bias))
    slack = 1.0 - radius / np.sqrt(sqr_length)
    active = slack > 0.0
    cur[active & (radius <= 0.0), 3] = 0.0
    cur[active, :3] += delta[active] * (slack[active] * float(stiffness))[:, None]
    return cur


def constrain_separation(centers, radii, cur):
    """Seed: d = c - p; slack = 1 - r / |d|; where slack < 0 the particle moves by d * slack
    (out to the sphere's surface). A particle exactly at the centre has no direction to leave
    by and stays (NvCloth's eps in |d| gives the same: its correction is 0 * slack)."""
    cur = np.array(cur, np.float64)
    d = np.asarray(centers, np.float64)[:, :3] - cur[:, :3]
    length = np.linalg.norm(d, axis=1)
    inside = (length > 0.0) & (cur[:, 3] != 0.0)  # immovable particles (w = 0) stay
    slack = np.zeros_like(length)
    slack[inside] = 1.0 - np.asarray(radii, np.float64)[inside] / length[inside]
    push = inside & (slack < 0.0)
    cur[push, :3] += d[push] * slack[push, None]
    return cur


def constrain_tethers(anchors, lengths, scale, stiffness, cur):
    """Seed: for each of particle i's k tethers (slot s at s*n + i), delta = anchor - p,
    slack = 1 - length*scale / (|delta| + eps), offset += delta * max(slack, 0); then
    p += offset * stiffness. Returns cur as a float64 copy.

    NvCloth's code regularises the length as sqrt(eps + |delta|^2) where the seed writes
    |delta| + eps; both only guard |delta| -> 0 and differ by < 1e-6 relative for
    |delta| >= 0.1 (the tests keep tethers that long, or exactly zero).
    """
    cur = np.array(cur, np.float64)
    n = cur.shape[0]
    if n == 0:
        return cur
    k = np.asarray(anchors).shape[0] // n
    anchor = np.asarray(anchors, np.int64).reshape(k, n)
    length = np.asarray(lengths, np.float64).reshape(k, n)
    delta = cur[anchor, :3] - cur[None, :, :3]  # (k, n, 3)
    slack = 1.0 - length * float(scale) / (np.linalg.norm(delta, axis=2) + DISTANCE_EPSILON)
    offset = (delta * np.maximum(slack, 0.0)[:, :, None]).sum(axis=0)
    cur[:, :3] += offset * float(stiffness)
    return cur
