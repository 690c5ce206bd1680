"""Per-frame measurements: constraint strain, particle speeds, kinetic energy, finiteness."""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel
from clothtool._simd import lane, load4, vmul, vsub

# Per-frame measurements run over particles and constraints STAT_BLOCK at a time: a loop
# that fills a block (speeds, edge lengths), then loops over the block's contiguous values
# that LLVM vectorises (square roots, divisions, sums). Maxima are kept in four
# running values (_block_max): one running maximum is a chain of dependent compares that
# cost 0.55 ns a value, four cost 0.15, and the maximum is the same value either way.
STAT_BLOCK = 256


@kernel(inline="always")
def _block_max(values, count, worst):
    """max(worst, values[0 : count]), NaN values skipped (as max(worst, NaN) = worst)."""
    w0 = w1 = w2 = w3 = worst
    whole = count - count % 4
    for i in range(0, whole, 4):
        w0 = max(w0, values[i])
        w1 = max(w1, values[i + 1])
        w2 = max(w2, values[i + 2])
        w3 = max(w3, values[i + 3])
    for i in range(whole, count):
        w0 = max(w0, values[i])
    return max(max(w0, w1), max(w2, w3))


@kernel(fastmath={"contract", "reassoc"})
def motion_summary(cur, prev, masses, inv_dt):
    """Over all particles: (max speed, kinetic energy, index of the fastest particle,
    index of the first non-finite particle or -1). Speeds from (cur - prev) / dt, the
    difference in the state's precision, the rest in float64. The energy is summed in
    float64, block by block in an order the code fixes (deterministic)."""
    n = cur.shape[0]
    flat = cur.reshape(-1)
    prev_flat = prev.reshape(-1)
    inv_dt_sqr = inv_dt * inv_dt
    speed_sqr = np.empty(STAT_BLOCK)
    max_speed_sqr = 0.0
    fastest = 0
    energy = 0.0
    bad = -1
    for block in range((n + STAT_BLOCK - 1) // STAT_BLOCK):
        lo = block * STAT_BLOCK
        count = min(STAT_BLOCK, n - lo)
        for k in range(count):
            d = vsub(load4(flat, 4 * (lo + k)), load4(prev_flat, 4 * (lo + k)))  # in the state's precision
            speed_sqr[k] = (np.float64(lane(d, 0)) ** 2 + np.float64(lane(d, 1)) ** 2 + np.float64(lane(d, 2)) ** 2) * inv_dt_sqr
        # Infinite or NaN exactly when one of the six coordinates is: differences of finite
        # float32 values (< 7e38) times any sane 1/dt cannot overflow float64 when squared
        # (a float64 state with coordinates near 1e150 has long exceeded solver.max_speed).
        # x - x is 0 for a finite x and NaN otherwise: one sum finds a block without any.
        check = 0.0
        for k in range(count):
            check += speed_sqr[k] - speed_sqr[k]
        if check != 0.0 or check != check:  # a non-finite speed: skip those one by one
            for k in range(count):
                s = speed_sqr[k]
                if not np.isfinite(s):
                    if bad < 0:
                        bad = lo + k
                    speed_sqr[k] = np.nan  # skipped by the maximum
                else:
                    energy += 0.5 * masses[lo + k] * s
        else:
            block_energy = 0.0
            for k in range(count):
                block_energy += 0.5 * masses[lo + k] * speed_sqr[k]
            energy += block_energy
        worst = _block_max(speed_sqr, count, max_speed_sqr)
        if worst > max_speed_sqr:  # the first particle of the block at the new maximum
            max_speed_sqr = worst
            for k in range(count):
                if speed_sqr[k] == worst:
                    fastest = lo + k
                    break
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


# Strains: measure a block's edges (row loads), then the square roots and divisions over
# the contiguous block, eight at a time. Indices are unsigned (np.uintp): no negative-index
# wraparound code to block the vectoriser.


@kernel(inline="always")
def _edge_strains(flat, indices, rest, lo, hi, out):
    """out[0 : hi - lo] = strain of constraints lo .. hi (flat: the (n*4,) particle view)."""
    for c in range(lo, hi):
        h = vsub(load4(flat, 4 * indices[c, 1]), load4(flat, 4 * indices[c, 0]))
        h2 = vmul(h, h)
        out[c - lo] = lane(h2, 0) + lane(h2, 1) + lane(h2, 2)
    for c in range(lo, hi):
        r = rest[c]
        out[c - lo] = np.sqrt(out[c - lo]) / r - np.float32(1.0) if r > 0 else np.float32(0.0)


@kernel
def constraint_strain(indices, rest, cur, strain):
    """strain[c] = |p_b - p_a| / rest - 1 (0 for zero rest length)."""
    flat = cur.reshape(-1)
    block_strain = np.empty(STAT_BLOCK, cur.dtype)  # in the state's precision
    n = indices.shape[0]
    for block in range((n + STAT_BLOCK - 1) // STAT_BLOCK):
        lo = np.uintp(block * STAT_BLOCK)
        hi = np.uintp(min(block * STAT_BLOCK + STAT_BLOCK, n))
        _edge_strains(flat, indices, rest, lo, hi, block_strain)
        for i in range(hi - lo):  # not a slice assignment: that compiles numba's shape-error message
            strain[lo + i] = block_strain[i]


@kernel(inline="always", fastmath={"contract", "reassoc"})
def _strain_extremes_between(indices, rest, cur, first, last):
    """(max strain, sum of strains) over constraints first .. last (see strain_extremes)."""
    flat = cur.reshape(-1)
    strain = np.empty(STAT_BLOCK, cur.dtype)
    worst = np.float32(-np.inf)
    total = 0.0
    n = last - first
    for block in range((n + STAT_BLOCK - 1) // STAT_BLOCK):
        lo = np.uintp(first + block * STAT_BLOCK)
        hi = np.uintp(first + min(block * STAT_BLOCK + STAT_BLOCK, n))
        _edge_strains(flat, indices, rest, lo, hi, strain)
        for i in range(hi - lo):  # apart from the max, so that the sum vectorises
            total += np.float64(strain[i])
        worst = _block_max(strain, hi - lo, worst)
    return np.float64(worst), total


# "reassoc" lets the float64 sum vectorise; its order is fixed by the code, so the result
# stays deterministic.
@kernel(fastmath={"contract", "reassoc"})
def strain_extremes(indices, rest, cur):
    """(max strain, sum of strains) over the constraints given: the same strain as
    ``constraint_strain``, reduced without storing it (float64 sum)."""
    return _strain_extremes_between(indices, rest, cur, 0, indices.shape[0])


@kernel(fastmath={"contract", "reassoc"})
def frame_summary(indices, rest, spans, cur, prev, masses, inv_dt, anchors, tether_lengths, span_max, span_sum):
    """A frame's stats in one call: span_max[s], span_sum[s] = strain_extremes over the
    constraints spans[s, 0] .. spans[s, 1]; returns motion_summary's (max speed, kinetic
    energy, fastest particle, first non-finite particle) and tether_stretch (0 without
    tethers)."""
    for s in range(spans.shape[0]):
        span_max[s], span_sum[s] = _strain_extremes_between(indices, rest, cur, spans[s, 0], spans[s, 1])
    speed, energy, fastest, bad = motion_summary(cur, prev, masses, inv_dt)
    return speed, energy, fastest, bad, tether_stretch(anchors, tether_lengths, cur)


@kernel
def upper_percentile(values, q):
    """np.percentile(values, q) (its default "linear" method), computed in float64, for q near
    100: the m values from the percentile's position up are kept in a min-heap while the array
    is read once, O(n + m log m) instead of np.percentile's partition of the whole array (which
    took a fifth of a 128^2 bake's frame for the report's p99 per phase type). NaN if any value
    is NaN or there are none."""
    n = values.shape[0]
    if n == 0:
        return np.nan
    position = (n - 1) * (q / 100.0)
    lo = min(int(np.floor(position)), n - 1)
    m = n - lo  # the m largest values: the smallest of them is sorted[lo]
    heap = np.empty(m, np.float64)
    size = 0
    for i in range(n):
        v = np.float64(values[i])
        if v != v:
            return np.nan
        if size < m:
            heap[size] = v
            j = size
            size += 1
            while j > 0 and heap[(j - 1) // 2] > heap[j]:
                parent = (j - 1) // 2
                heap[parent], heap[j] = heap[j], heap[parent]
                j = parent
        elif v > heap[0]:
            heap[0] = v
            j = 0
            while True:
                smallest = j
                for child in range(2 * j + 1, min(2 * j + 3, m)):
                    if heap[child] < heap[smallest]:
                        smallest = child
                if smallest == j:
                    break
                heap[smallest], heap[j] = heap[j], heap[smallest]
                j = smallest
    below = heap[0]
    if m == 1:
        return below
    above = heap[1] if m == 2 else min(heap[1], heap[2])  # sorted[lo + 1]: the heap's second smallest
    t = position - lo
    difference = above - below
    # numpy's interpolation, which rounds from the nearer end
    return above - difference * (1.0 - t) if t >= 0.5 else below + difference * t
