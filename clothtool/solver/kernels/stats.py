"""Per-frame measurements: constraint strain, particle speeds, kinetic energy, finiteness."""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel
from clothtool._simd import lane, load4, vmul, vsub


@kernel
def constraint_strain(indices, rest, cur, strain):
    """strain[c] = |p_b - p_a| / rest - 1 (0 for zero rest length)."""
    for c in range(indices.shape[0]):
        a = indices[c, 0]
        b = indices[c, 1]
        dx = cur[b, 0] - cur[a, 0]
        dy = cur[b, 1] - cur[a, 1]
        dz = cur[b, 2] - cur[a, 2]
        length = np.sqrt(dx * dx + dy * dy + dz * dz)
        r = rest[c]
        strain[c] = length / r - np.float32(1.0) if r > 0 else np.float32(0.0)


@kernel
def motion_summary(cur, prev, masses, inv_dt):
    """Over all particles: (max speed, kinetic energy, index of the fastest particle,
    index of the first non-finite particle or -1). Speeds from (cur - prev) / dt; float64 sums."""
    max_speed_sqr = 0.0
    fastest = 0
    energy = 0.0
    bad = -1
    for i in range(cur.shape[0]):
        vx = (np.float64(cur[i, 0]) - np.float64(prev[i, 0])) * inv_dt
        vy = (np.float64(cur[i, 1]) - np.float64(prev[i, 1])) * inv_dt
        vz = (np.float64(cur[i, 2]) - np.float64(prev[i, 2])) * inv_dt
        speed_sqr = vx * vx + vy * vy + vz * vz
        # Infinite or NaN exactly when one of the six coordinates is: differences of finite
        # float32 values (< 7e38) times any sane 1/dt cannot overflow float64 when squared.
        if not np.isfinite(speed_sqr):
            if bad < 0:
                bad = i
            continue
        if speed_sqr > max_speed_sqr:
            max_speed_sqr = speed_sqr
            fastest = i
        energy += 0.5 * masses[i] * speed_sqr
    return np.sqrt(max_speed_sqr), energy, fastest, bad


@kernel
def tether_stretch(anchors, lengths, cur):
    """Largest tether stretch |p - anchor| / length - 1 over active tethers; 0 when no tether
    is stretched (slack tethers do not count as negative stretch).

    The largest |d| / length is the square root of the largest |d|^2 / length^2: one division
    per tether and a single square root (the division and square root per tether were most
    of the stats' time)."""
    n = cur.shape[0]
    if n == 0:
        return 0.0
    flat = cur.reshape(-1)
    worst_sqr = 1.0  # (1 + stretch)^2 of the most stretched tether; 1: none stretched
    for s in range(anchors.shape[0] // n):
        for i in range(n):
            t = s * n + i
            a = anchors[t]
            length = np.float64(lengths[t])
            if a == i or length <= 0.0:
                continue
            d = vsub(load4(flat, 4 * a), load4(flat, 4 * i))  # float32 differences, as before
            dx = np.float64(lane(d, 0))
            dy = np.float64(lane(d, 1))
            dz = np.float64(lane(d, 2))
            worst_sqr = max(worst_sqr, (dx * dx + dy * dy + dz * dz) / (length * length))
    return np.sqrt(worst_sqr) - 1.0


# strain_extremes runs every frame over every constraint, so it measures BLOCK constraints at a
# time (row loads), then computes their strains in a loop LLVM vectorises (square roots and
# divisions eight at a time), then reduces. "reassoc" lets the float64 sum vectorise too: its
# order is fixed by the code, so results stay deterministic.
STRAIN_BLOCK = 256


@kernel(fastmath={"contract", "reassoc"})
def strain_extremes(indices, rest, cur):
    """(max strain, sum of strains) over the constraints given: the same strain as
    ``constraint_strain``, reduced without storing it (float64 sum)."""
    flat = cur.reshape(-1)
    strain = np.empty(STRAIN_BLOCK, cur.dtype)
    worst = np.float32(-np.inf)
    total = 0.0
    n = indices.shape[0]
    for block in range((n + STRAIN_BLOCK - 1) // STRAIN_BLOCK):
        # unsigned indices: no negative-index wraparound code, which blocks vectorisation
        lo = np.uintp(block * STRAIN_BLOCK)
        hi = np.uintp(min(block * STRAIN_BLOCK + STRAIN_BLOCK, n))
        for c in range(lo, hi):
            h = vsub(load4(flat, 4 * indices[c, 1]), load4(flat, 4 * indices[c, 0]))
            h2 = vmul(h, h)
            strain[c - lo] = lane(h2, 0) + lane(h2, 1) + lane(h2, 2)
        for c in range(lo, hi):
            r = rest[c]
            strain[c - lo] = np.sqrt(strain[c - lo]) / r - np.float32(1.0) if r > 0 else np.float32(0.0)
        for i in range(hi - lo):  # apart from the max, so that the sum vectorises
            total += np.float64(strain[i])
        for i in range(hi - lo):
            worst = max(worst, strain[i])
    return np.float64(worst), total
