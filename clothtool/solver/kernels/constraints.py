"""Per-particle sphere constraints: motion (max distance), separation, and tethers.

These follow the seed's pseudo-code: motion constraints keep a particle inside a sphere
(radius <= 0 pins it for the iteration by zeroing cur.w), separation constraints keep it
outside one, and tethers pull a particle back towards its pinned anchors.
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel
from clothtool._minmax import largest, smallest
from clothtool._simd import fill, keep_w, lane, load4, store4, vadd, vmul, vsub

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
        radius = largest(zero, radii[i] * scale + bias)
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


# Tethers are solved for TETHER_BLOCK particles at a time, slot by slot in three passes
# (measure, slack, accumulate the pull), then the block moves: the square root and division
# of the slack pass vectorise over contiguous scratch, which a particle-at-a-time loop cannot.
# Anchors are pinned, so no pass sees another's writes.
TETHER_BLOCK = 256


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
    flat = cur.reshape(-1)
    slack = np.empty(TETHER_BLOCK, cur.dtype)
    pull = np.empty(4 * TETHER_BLOCK, cur.dtype)  # per particle of the block: sum of delta * slack
    zero = np.float32(0.0)
    one = np.float32(1.0)
    for block in range((n + TETHER_BLOCK - 1) // TETHER_BLOCK):
        # unsigned indices: no negative-index wraparound code, which blocks vectorisation
        lo = np.uintp(block * TETHER_BLOCK)
        hi = np.uintp(smallest(block * TETHER_BLOCK + TETHER_BLOCK, n))
        pull[:] = 0.0
        for s in range(k):
            slot = np.uintp(s * n)
            for i in range(lo, hi):
                delta = vsub(load4(flat, 4 * anchors[slot + i]), load4(flat, 4 * i))
                delta2 = vmul(delta, delta)
                slack[i - lo] = DISTANCE_EPSILON + lane(delta2, 0) + lane(delta2, 1) + lane(delta2, 2)
            for i in range(lo, hi):
                slack[i - lo] = largest(one - lengths[slot + i] * scale / np.sqrt(slack[i - lo]), zero)
            for i in range(lo, hi):
                delta = vsub(load4(flat, 4 * anchors[slot + i]), load4(flat, 4 * i))
                row = 4 * (i - lo)
                store4(pull, row, vadd(load4(pull, row), vmul(delta, fill(delta, slack[i - lo]))))
        for i in range(lo, hi):
            p = load4(flat, 4 * i)
            store4(flat, 4 * i, keep_w(vadd(p, vmul(load4(pull, 4 * (i - lo)), fill(p, stiffness))), p))
