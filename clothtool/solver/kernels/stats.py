"""Per-frame measurements: constraint strain, particle speeds, kinetic energy, finiteness."""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel
from clothtool._minmax import largest, smallest
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
        w0 = largest(w0, values[i])
        w1 = largest(w1, values[i + 1])
        w2 = largest(w2, values[i + 2])
        w3 = largest(w3, values[i + 3])
    for i in range(whole, count):
        w0 = largest(w0, values[i])
    return largest(largest(w0, w1), largest(w2, w3))


@kernel(device=True, fastmath={"contract", "reassoc"})
def motion_summary(cur, prev, masses, inv_dt):
    """Over all particles: (max speed, kinetic energy, index of the fastest particle,
    index of the first non-finite particle or -1). Speeds from (cur - prev) / dt, the
    difference in the state's precision, the rest in float64. The energy is summed in
    float64, block by block in an order the code fixes (deterministic)."""
    n = cur.shape[0]
    flat = cur.reshape(-1)
    prev_flat = prev.reshape(-1)
    inv_dt_sqr = inv_dt * inv_dt
    speed_sqr = np.empty(np.int64(STAT_BLOCK), np.float64)  # typed as frame_summary's candidates: one np.empty compiled
    max_speed_sqr = 0.0
    fastest = 0
    energy = 0.0
    bad = -1
    for block in range((n + STAT_BLOCK - 1) // STAT_BLOCK):
        lo = block * STAT_BLOCK
        count = smallest(STAT_BLOCK, n - lo)
        for k in range(count):
            d = vsub(load4(flat, 4 * (lo + k)), load4(prev_flat, 4 * (lo + k)))  # in the state's precision
            dx, dy, dz = np.float64(lane(d, 0)), np.float64(lane(d, 1)), np.float64(lane(d, 2))
            speed_sqr[k] = (dx * dx + dy * dy + dz * dz) * inv_dt_sqr  # x * x, not x ** 2: that compiles numba's int_power
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


@kernel(device=True)
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
            worst_sqr = largest(worst_sqr, (dx * dx + dy * dy + dz * dz) / (length * length))
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
        hi = np.uintp(smallest(block * STAT_BLOCK + STAT_BLOCK, n))
        _edge_strains(flat, indices, rest, lo, hi, block_strain)
        for i in range(hi - lo):  # not a slice assignment: that compiles numba's shape-error message
            strain[lo + i] = block_strain[i]


@kernel(inline="always", fastmath={"contract", "reassoc"})
def _strain_extremes_between(indices, rest, cur, first, last, top, count, threshold, m):
    """(max strain, sum of strains, count, threshold) over constraints first .. last (see
    strain_extremes); with m > 0 each strain is also offered to the candidates ``top`` of the
    m largest (see _offer_block). A block whose largest strain is not above the threshold is
    skipped whole: _offer_block would turn each of its values away."""
    flat = cur.reshape(-1)
    strain = np.empty(STAT_BLOCK, cur.dtype)
    worst = np.float32(-np.inf)
    total = 0.0
    n = last - first
    for block in range((n + STAT_BLOCK - 1) // STAT_BLOCK):
        lo = np.uintp(first + block * STAT_BLOCK)
        hi = np.uintp(first + smallest(block * STAT_BLOCK + STAT_BLOCK, n))
        _edge_strains(flat, indices, rest, lo, hi, strain)
        for i in range(hi - lo):  # apart from the max, so that the sum vectorises
            total += np.float64(strain[i])
        # the count and start typed as motion_summary's call types them: a float64 state
        # compiles one _block_max, not two (the maximum's value is the same)
        block_worst = _block_max(strain, np.int64(hi - lo), strain.dtype.type(-np.inf))
        worst = largest(worst, block_worst)
        if m > 0 and not np.float64(block_worst) <= threshold:
            count, threshold = _offer_block(top, count, threshold, m, strain, hi - lo)
    return np.float64(worst), total, count, threshold


# "reassoc" lets the float64 sum vectorise; its order is fixed by the code, so the result
# stays deterministic.
@kernel(fastmath={"contract", "reassoc"})
def strain_extremes(indices, rest, cur):
    """(max strain, sum of strains) over the constraints given: the same strain as
    ``constraint_strain``, reduced without storing it (float64 sum)."""
    worst, total, _, _ = _strain_extremes_between(indices, rest, cur, 0, indices.shape[0], np.empty(0), 0, np.nan, 0)
    return worst, total


@kernel(fastmath={"contract", "reassoc"})
def frame_summary(indices, rest, spans, groups, members, particles, tethers, q, cur, prev, masses, inv_dt, anchors,
                  tether_lengths, span_max, span_sum, percentiles, motion):
    """A frame's stats of one cloth or of several (the members of a merged solve) in one call.

    Member j owns particles particles[j] .. particles[j + 1] of cur, prev and masses, tether
    slots tethers[j] .. tethers[j + 1] of anchors and tether_lengths, and groups members[j] ..
    members[j + 1]; group g is one phase type's constraint spans groups[g] .. groups[g + 1],
    span s the constraints spans[s, 0] .. spans[s, 1] of indices and rest. Constraint and
    tether indices count from the member's first particle (a member's arrays are those it
    has when measured alone, concatenated).

    span_max[s], span_sum[s] = strain_extremes over span s; percentiles[g] (when given: one
    per group, else empty) = upper_percentile(strains, q) over group g's strains as if they
    were one array (offered to the candidates as they are measured, none stored);
    motion[j] = member j's motion_summary (max speed, kinetic energy, fastest particle,
    first non-finite particle) and tether_stretch (0 without tethers). Each figure has the
    bits the member's own call gives.

    A group's figures are worked out here rather than in a helper of their own: each helper
    is a compilation of its own whose LLVM code, with all it inlines, every caller optimises
    again (that level cost ~0.3 s of the ~2.5 s CPU a cold start spent compiling the stats
    kernels). motion_summary and tether_stretch are device kernels: called from here, they
    compile without the CPython wrapper only a call from Python needs."""
    for j in range(members.shape[0] - 1):
        own, own_prev = cur[particles[j] : particles[j + 1]], prev[particles[j] : particles[j + 1]]
        for g in range(members[j], members[j + 1]):  # group g's strain figures
            n = 0
            for s in range(groups[g], groups[g + 1]):
                n += spans[s, 1] - spans[s, 0]
            position, lo, m = _percentile_rank(n, q)
            if percentiles.shape[0] == 0:
                m = 0
            top = np.empty(_candidates(m), np.float64)
            count, threshold = 0, np.nan
            nan = False
            for s in range(groups[g], groups[g + 1]):
                span_max[s], span_sum[s], count, threshold = _strain_extremes_between(
                    indices, rest, own, spans[s, 0], spans[s, 1], top, count, threshold, m
                )
                nan = nan or span_sum[s] != span_sum[s]  # a NaN strain makes the sum NaN (strains are >= -1)
            if m > 0:
                percentiles[g] = np.nan if n == 0 or nan else _top_percentile(top, count, m, position, lo)
        speed, energy, fastest, bad = motion_summary(own, own_prev, masses[particles[j] : particles[j + 1]], inv_dt)
        motion[j, 0] = speed
        motion[j, 1] = energy
        motion[j, 2] = fastest
        motion[j, 3] = bad
        motion[j, 4] = tether_stretch(anchors[tethers[j] : tethers[j + 1]], tether_lengths[tethers[j] : tethers[j + 1]], own)


# Upper percentiles (the report's p99) from one pass over the values: values above a
# threshold are appended to a buffer of candidates; when it fills, a selection (_select)
# keeps the m largest and their least becomes the threshold. Most values are turned away by
# one compare (every value is written, and counted only when taken), so this costs about what
# the strains themselves cost, where a heap of the m largest cost three times that on a
# hanging cloth (whose strains grow along the constraint order, so most values entered it).


@kernel(inline="always")
def _percentile_rank(n, q):
    """(position, lo, m) of np.percentile(values, q) over n values: the percentile lies at
    ``position`` in the sorted values, between sorted[lo] and sorted[lo + 1], and the m = n - lo
    largest values hold both."""
    position = (n - 1) * (q / 100.0)
    lo = smallest(np.int64(np.floor(position)), n - 1)  # np.int64, not int(): no overload to compile
    return position, lo, largest(n - lo, 0)


@kernel(inline="always")
def _candidates(m):
    """The size of the candidate buffer for the m largest values (none for m = 0): room for
    4m (pruned when they are there) and one more block of values."""
    return 0 if m == 0 else largest(4 * m, 64) + STAT_BLOCK


@kernel(inline="always")
def _offer_block(top, count, threshold, m, values, n):
    """Offer values[0 : n] to the candidates top[0 : count] for the m largest values seen;
    returns the new (count, threshold). The threshold is NaN until the first prune (every
    value is a candidate), then the least of the m largest so far: a value not above it cannot
    be one of them (one equal to it would only stand for an equal one). NaN values are not
    taken (the callers find them otherwise)."""
    for i in range(n):
        v = np.float64(values[i])
        top[count] = v
        count += v == v and not v <= threshold
    if count >= top.shape[0] - STAT_BLOCK:
        count, threshold = _prune(top, count, m)
    return count, threshold


@kernel(inline="always")
def _select(values, count, k):
    """Reorder values[0 : count] so that values[k] is the one sorted order puts there, with
    none larger before it and none smaller after it (Hoare's selection, the middle value as
    pivot; no NaN among them). Written here rather than np.partition: numba's partition
    compiles for ~8 s CPU, longer than every other stats kernel together."""
    lo, hi = 0, count - 1
    while lo < hi:
        pivot = values[(lo + hi) // 2]
        i, j = lo, hi
        while i <= j:
            while values[i] < pivot:
                i += 1
            while values[j] > pivot:
                j -= 1
            if i <= j:
                values[i], values[j] = values[j], values[i]
                i += 1
                j -= 1
        if j < k:  # values[lo : j + 1] <= pivot <= values[i : hi + 1], values between them == pivot
            lo = i
        if k < i:
            hi = j


@kernel(inline="always")
def _prune(top, count, m):
    """Keep the m largest of top[0 : count] in top[0 : m]; returns (m, the least of them)."""
    _select(top, count, count - m)
    for i in range(m):
        top[i] = top[count - m + i]
    return m, top[0]


@kernel(inline="always")
def _top_percentile(top, count, m, position, lo):
    """The percentile at ``position`` (see _percentile_rank) from the candidates top[0 : count],
    which hold the m largest values (count >= m)."""
    first = count - m
    _select(top, count, first)
    below = top[first]  # sorted[lo]
    if m == 1:
        return below
    above = top[first + 1]  # sorted[lo + 1]: the least of the others
    for i in range(first + 2, count):
        above = smallest(above, top[i])
    t = position - lo
    difference = above - below
    # numpy's interpolation, which rounds from the nearer end
    return above - difference * (1.0 - t) if t >= 0.5 else below + difference * t


@kernel
def upper_percentile(values, q):
    """np.percentile(values, q) (its default "linear" method), computed in float64, for q near
    100, in one pass over the values (see _offer_block) instead of np.percentile's partition
    of the whole array (which took a fifth of a 128^2 bake's frame for the report's p99 per
    phase type). NaN if any value is NaN or there are none."""
    n = values.shape[0]
    if n == 0:
        return np.nan
    position, lo, m = _percentile_rank(n, q)
    top = np.empty(_candidates(m), np.float64)
    count, threshold = 0, np.nan
    for first in range(0, n, STAT_BLOCK):
        block = values[first : smallest(first + STAT_BLOCK, n)]
        for i in range(block.shape[0]):
            if block[i] != block[i]:
                return np.nan
        count, threshold = _offer_block(top, count, threshold, m, block, block.shape[0])
    return _top_percentile(top, count, m, position, lo)
