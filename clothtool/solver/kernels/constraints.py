"""Per-particle sphere constraints: motion (max distance), separation, and tethers.

These follow the seed's pseudo-code: motion constraints keep a particle inside a sphere
(radius <= 0 pins it for the iteration by zeroing cur.w), separation constraints keep it
outside one, and tethers pull a particle back towards its pinned anchors.
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel

# Guards sqrt and division when two particles coincide. NvCloth adds FLT_EPSILON here, which
# is in scene units squared: a 2 mm edge in a metre scene would rest 1.5% short and edges
# under 0.35 mm could never be satisfied. A guard far below any real length squared keeps
# the formulas exact while still avoiding 0/0.
DISTANCE_EPSILON = np.float32(1e-30)


@kernel
def constrain_motion(centers, radii, scale, bias, stiffness, cur):
    """Keep particle i within radius max(0, radii[i] * scale + bias) of centers[i]."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    for i in range(cur.shape[0]):
        dx = centers[i, 0] - cur[i, 0]
        dy = centers[i, 1] - cur[i, 1]
        dz = centers[i, 2] - cur[i, 2]
        sqr_length = DISTANCE_EPSILON + dx * dx + dy * dy + dz * dz
        radius = max(zero, radii[i] * scale + bias)
        slack = one - radius / np.sqrt(sqr_length)
        if slack > zero:
            if radius <= zero:
                cur[i, 3] = zero
            slack *= stiffness
            cur[i, 0] += dx * slack
            cur[i, 1] += dy * slack
            cur[i, 2] += dz * slack


@kernel
def constrain_separation(centers, radii, cur):
    """Keep particle i outside the sphere (centers[i], radii[i]); particles with cur.w = 0
    (pinned, or held by a motion constraint this iteration) are never moved."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    for i in range(cur.shape[0]):
        if cur[i, 3] == zero:
            continue
        dx = centers[i, 0] - cur[i, 0]
        dy = centers[i, 1] - cur[i, 1]
        dz = centers[i, 2] - cur[i, 2]
        length = np.sqrt(dx * dx + dy * dy + dz * dz)
        if length == zero:
            continue
        slack = one - radii[i] / length
        if slack < zero:
            cur[i, 0] += dx * slack
            cur[i, 1] += dy * slack
            cur[i, 2] += dz * slack


@kernel
def constrain_tethers(anchors, lengths, scale, stiffness, cur):
    """Tethers: anchors/lengths (k*n,), slot s of particle i at s*n + i.

    stiffness is the per-iteration tether stiffness times n / (k*n), as NvCloth scales it.
    Anchors are pinned particles, which this kernel never moves.
    """
    n = cur.shape[0]
    if n == 0:
        return
    k = anchors.shape[0] // n
    zero = np.float32(0.0)
    one = np.float32(1.0)
    for i in range(n):
        px = cur[i, 0]
        py = cur[i, 1]
        pz = cur[i, 2]
        ox = zero
        oy = zero
        oz = zero
        for s in range(k):
            t = s * n + i
            a = anchors[t]
            dx = cur[a, 0] - px
            dy = cur[a, 1] - py
            dz = cur[a, 2] - pz
            sqr_length = DISTANCE_EPSILON + dx * dx + dy * dy + dz * dz
            slack = one - lengths[t] * scale / np.sqrt(sqr_length)
            slack = max(slack, zero)
            ox += dx * slack
            oy += dy * slack
            oz += dz * slack
        cur[i, 0] = px + ox * stiffness
        cur[i, 1] = py + oy * stiffness
        cur[i, 2] = pz + oz * stiffness
