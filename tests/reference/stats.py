"""Reference for clothtool.solver.kernels.stats (per-frame measurements), vectorised, float64."""

from __future__ import annotations

import numpy as np


def constraint_strain(indices, rest, cur, strain=None):
    """Returns (c,) |p_b - p_a| / rest - 1, and 0 where the rest length is 0 (``strain``, the
    kernel's output array, is not needed)."""
    indices = np.asarray(indices, np.int64).reshape(-1, 2)
    p = np.asarray(cur, np.float64)[:, :3]
    rest = np.asarray(rest, np.float64)
    length = np.linalg.norm(p[indices[:, 1]] - p[indices[:, 0]], axis=1)
    out = np.zeros(rest.shape[0])
    positive = rest > 0.0
    out[positive] = length[positive] / rest[positive] - 1.0
    return out


def _nonfinite(cur, prev):
    """bool (n,): particles whose position or previous position is not finite."""
    cur, prev = np.asarray(cur)[:, :3], np.asarray(prev)[:, :3]
    return ~(np.isfinite(cur).all(axis=1) & np.isfinite(prev).all(axis=1))


def motion_summary(cur, prev, masses, inv_dt):
    """(max speed, kinetic energy, index of the fastest particle, index of the first
    non-finite particle or -1) over the finite particles, with speeds (cur - prev) / dt.

    The fastest particle is the first one with the top speed. When no finite particle moves,
    every one of them is "fastest"; this returns the first finite one (0 if there is none),
    and the tests do not hold the kernel to that choice.
    """
    bad = _nonfinite(cur, prev)
    good = ~bad
    with np.errstate(invalid="ignore"):  # inf - inf on the non-finite particles
        v = (np.asarray(cur, np.float64)[:, :3] - np.asarray(prev, np.float64)[:, :3]) * float(inv_dt)
    v[bad] = 0.0
    speed_sqr = np.einsum("ij,ij->i", v, v)
    if not good.any():
        return 0.0, 0.0, 0, int(np.flatnonzero(bad)[0]) if bad.size else -1
    fastest = int(np.argmax(np.where(good, speed_sqr, -np.inf)))
    energy = float(0.5 * (np.asarray(masses, np.float64)[good] * speed_sqr[good]).sum())
    first_bad = int(np.flatnonzero(bad)[0]) if bad.any() else -1
    return float(np.sqrt(speed_sqr[fastest])), energy, fastest, first_bad


def tether_stretch(anchors, lengths, cur):
    """Largest |p_i - p_anchor| / length - 1 over the active tethers (slot s of particle i at
    s*n + i; inactive slots point at i itself or have length 0). A tether is a max-distance
    constraint: a slack one is not stretched, so the result is never below 0 (0 if none)."""
    p = np.asarray(cur, np.float64)[:, :3]
    n = p.shape[0]
    anchors = np.asarray(anchors, np.int64)
    lengths = np.asarray(lengths, np.float64)
    own = np.arange(anchors.shape[0]) % n if n else np.zeros(0, np.int64)
    active = (anchors != own) & (lengths > 0.0)
    if not active.any():
        return 0.0
    ratio = np.linalg.norm(p[anchors[active]] - p[own[active]], axis=1) / lengths[active] - 1.0
    return max(0.0, float(ratio.max()))


def _block_max(values, count, worst):
    """max(worst, values[0 : count]) with NaN values skipped."""
    values = np.asarray(values, np.float64)[:count]
    values = values[~np.isnan(values)]
    return max(float(worst), float(values.max())) if values.size else worst


def strain_extremes(indices, rest, cur):
    """(max, sum) of constraint_strain over the given constraints (-inf, 0 when none)."""
    strain = constraint_strain(indices, rest, cur)
    return (float(strain.max()) if strain.size else -np.inf), float(strain.sum())


def _strain_extremes_between(indices, rest, cur, first, last):
    """strain_extremes over constraints first .. last."""
    return strain_extremes(np.asarray(indices)[first:last], np.asarray(rest)[first:last], cur)


def frame_summary(indices, rest, spans, groups, q, cur, prev, masses, inv_dt, anchors, tether_lengths, span_max, span_sum,
                  percentiles):
    """One cloth's frame_summary (the kernel's with one member owning everything):
    strain_extremes per span into span_max, span_sum; upper_percentile(q) of the strains of
    spans groups[g] .. groups[g + 1] into percentiles[g] when percentiles is not empty;
    returns motion_summary's four values and tether_stretch."""
    spans = np.asarray(spans)
    for s, (first, last) in enumerate(spans):
        span_max[s], span_sum[s] = _strain_extremes_between(indices, rest, cur, first, last)
    for g in range(len(percentiles)):
        strains = [constraint_strain(np.asarray(indices)[a:b], np.asarray(rest)[a:b], cur) for a, b in spans[groups[g] : groups[g + 1]]]
        percentiles[g] = upper_percentile(np.concatenate([np.zeros(0), *strains]), q)
    return (*motion_summary(cur, prev, masses, inv_dt), tether_stretch(anchors, tether_lengths, cur))


def _edge_strains(flat, indices, rest, lo, hi, out=None):
    """Returns the strains of constraints lo .. hi (flat: the (n*4,) particle view)."""
    return constraint_strain(np.asarray(indices)[lo:hi], np.asarray(rest)[lo:hi], np.asarray(flat).reshape(-1, 4))


def upper_percentile(values, q):
    """np.percentile in float64 (NaN for no values or a NaN among them)."""
    values = np.asarray(values, np.float64)
    if values.size == 0 or np.isnan(values).any():
        return np.nan
    return float(np.percentile(values, q))


def _percentile_rank(n, q):
    """(position, lo, m): np.percentile's position over n sorted values, the index below it,
    and how many values lie from there up."""
    position = (n - 1) * (q / 100.0)
    lo = min(int(np.floor(position)), n - 1)
    return position, lo, max(n - lo, 0)


def _candidates(m):
    """The candidate buffer's size for the m largest values: 4m (at least 64) and a block."""
    return 0 if m == 0 else max(4 * m, 64) + 256


def _select(values, count, k):
    """values[0 : count] reordered with the k-th smallest at k (np.partition's order)."""
    values[:count] = np.partition(values[:count], k)


def _prune(top, count, m):
    """The m largest of top[0 : count] into top[0 : m]; returns (m, their least)."""
    kept = np.sort(top[:count])[count - m :]
    top[:m] = kept
    return m, kept[0]


def _offer_block(top, count, threshold, m, values, n):
    """The non-NaN values[0 : n] not at or below ``threshold`` (every one while it is NaN)
    appended to top[count:]; pruned to the m largest when the buffer is full but a block."""
    v = np.asarray(values[:n], np.float64)
    taken = v[~np.isnan(v) & ~(v <= threshold)]
    top[count : count + taken.size] = taken
    count += taken.size
    if count >= top.shape[0] - 256:
        count, threshold = _prune(top, count, m)
    return count, threshold


def _top_percentile(top, count, m, position, lo):
    """np.percentile's linear interpolation between the two least of the m largest of
    top[0 : count] (sorted[lo] and sorted[lo + 1])."""
    kept = np.sort(top[:count])[count - m :]
    below = kept[0]
    if m == 1:
        return below
    above = kept[1]
    t = position - lo
    return above - (above - below) * (1.0 - t) if t >= 0.5 else below + (above - below) * t
