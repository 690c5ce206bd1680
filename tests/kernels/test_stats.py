"""constraint_strain / motion_summary / tether_stretch / frame_summary against tests/reference/stats.py."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clothtool.solver.kernels.stats import (
    constraint_strain,
    frame_summary,
    motion_summary,
    strain_extremes,
    tether_stretch,
    upper_percentile,
)
from tests.kernels._data import U, assert_close, f32, particles
from tests.reference import stats as ref

seeds = st.integers(0, 2**32 - 1)
INV_DT = 240.0


def strain_of(indices, rest, cur):
    out = np.full(rest.shape[0], np.nan, np.float32)
    constraint_strain(indices, rest, cur, out)
    return out


@settings(max_examples=25)
@given(seed=seeds, n=st.integers(2, 40), c=st.integers(0, 80))
def test_strain_matches_reference(seed, n, c):
    rng = np.random.default_rng(seed)
    cur, _ = particles(rng, n)
    indices = np.ascontiguousarray(rng.integers(0, n, (c, 2)), np.int32)
    p = cur[:, :3].astype(np.float64)
    rest = np.linalg.norm(p[indices[:, 1]] - p[indices[:, 0]], axis=1) * rng.uniform(0.7, 1.3, c)
    rest = np.where(rest < 0.05, 0.0, rest)  # short and self pairs: rest length 0, strain 0
    rest[rng.random(c) < 0.1] = 0.0
    rest = f32(rest)
    got = strain_of(indices, rest, cur)
    want = ref.constraint_strain(indices, rest, cur)
    # float32 throughout: a float32 difference is within U of its own value (relative), then
    # three squares, two sums, a sqrt and a division each add U relative to |h| / r = strain + 1,
    # and the final - 1 rounds once more
    assert_close(got, want, 10 * U * (np.abs(want) + 1), "strain")
    np.testing.assert_array_equal(got[rest == 0], 0.0)
    # the reduction sees the same strains: max within the same bound, sum within c of them
    worst, total = strain_extremes(indices, rest, cur)
    want_worst, want_total = ref.strain_extremes(indices, rest, cur)
    if c:
        assert worst == pytest.approx(want_worst, abs=10 * U * (abs(want_worst) + 1))
        assert total == pytest.approx(want_total, abs=10 * U * float(np.sum(np.abs(want) + 1)) + 1e-12)
    else:
        assert worst == -np.inf and total == 0.0


@settings(max_examples=30)
@given(seed=seeds, n=st.integers(0, 60), broken=st.floats(0.0, 0.3))
def test_motion_summary_matches_reference(seed, n, broken):
    rng = np.random.default_rng(seed)
    cur, prev = particles(rng, n, speed=0.01)
    masses = rng.uniform(0.001, 0.01, n)
    bad = rng.random(n) < broken
    where = rng.integers(0, 3, n)
    cur[bad & (where == 0), rng.integers(0, 3)] = np.nan
    cur[bad & (where == 1), rng.integers(0, 3)] = np.inf
    prev[bad & (where == 2), rng.integers(0, 3)] = -np.inf
    speed, energy, fastest, first_bad = motion_summary(cur, prev, masses, INV_DT)
    want_speed, want_energy, want_fastest, want_bad = ref.motion_summary(cur, prev, masses, INV_DT)
    # the kernel takes cur - prev in float32, within U of the exact difference (relative, per
    # component), and sums in float64: speeds within ~U and energies within ~2U, relative
    assert speed == pytest.approx(want_speed, rel=4 * U, abs=1e-300)
    assert energy == pytest.approx(want_energy, rel=8 * U, abs=1e-300)
    assert first_bad == want_bad
    if want_speed > 0:  # the fastest particle is unique (random speeds)
        assert fastest == want_fastest


@settings(max_examples=15)
@given(seed=seeds, n=st.integers(300, 1100), broken=st.sampled_from([0.0, 0.002, 0.05]), tie=st.booleans())
def test_summaries_over_many_blocks(seed, n, broken, tie):
    """Over several of the kernels' blocks (STAT_BLOCK values each): the maximum, its first
    particle, the first non-finite particle and the sums, whichever block they fall in."""
    from clothtool.solver.kernels.stats import STAT_BLOCK

    rng = np.random.default_rng(seed)
    cur, prev = particles(rng, n, speed=0.01)
    masses = rng.uniform(0.001, 0.01, n)
    if tie:  # the top speed twice, in two blocks: the first particle is the fastest
        first, second = sorted(rng.choice(n, 2, replace=False))
        cur[first, :3] = prev[first, :3] + np.float32(0.5)
        cur[second], prev[second] = cur[first], prev[first]  # the very same speed
    bad = np.flatnonzero(rng.random(n) < broken)
    cur[bad, 1] = np.nan
    speed, energy, fastest, first_bad = motion_summary(cur, prev, masses, INV_DT)
    want_speed, want_energy, want_fastest, want_bad = ref.motion_summary(cur, prev, masses, INV_DT)
    assert n > STAT_BLOCK
    assert speed == pytest.approx(want_speed, rel=4 * U)
    assert energy == pytest.approx(want_energy, rel=8 * U)
    assert (fastest, first_bad) == (want_fastest, want_bad)
    c = 3 * n
    indices = np.ascontiguousarray(rng.integers(0, n, (c, 2)), np.int32)
    rest = f32(rng.uniform(0.5, 1.5, c))
    worst, total = strain_extremes(indices, rest, cur)
    strains = ref.constraint_strain(indices, rest, cur)
    finite = np.isfinite(strains)
    assert worst == pytest.approx(strains[finite].max(), abs=10 * U * (abs(strains[finite].max()) + 1))


@settings(max_examples=40)
@given(seed=seeds, n=st.integers(0, 40), count=st.integers(0, 40), nans=st.floats(0.0, 0.5), start=st.sampled_from([-np.inf, 0.0, 0.3]))
def test_block_max_matches_reference(seed, n, count, nans, start):
    """Four running maxima give the one maximum, NaN skipped, whatever count % 4 is."""
    from clothtool.solver.kernels.stats import _block_max

    rng = np.random.default_rng(seed)
    values = rng.normal(0.0, 1.0, max(n, count))
    values[rng.random(values.shape[0]) < nans] = np.nan
    assert _block_max(values, count, start) == ref._block_max(values, count, start)


def test_motion_summary_edge_cases():
    masses = np.ones(3)
    rest = f32([[0, 0, 0, 1], [1, 1, 1, 1], [2, 2, 2, 1]])
    assert motion_summary(rest, rest.copy(), masses, INV_DT) == (0.0, 0.0, 0, -1)
    empty = np.zeros((0, 4), np.float32)
    assert motion_summary(empty, empty, np.zeros(0), INV_DT) == (0.0, 0.0, 0, -1)
    cur = rest.copy()
    cur[1, 0] += np.float32(0.5)
    cur[2, 1] = np.nan
    speed, energy, fastest, bad = motion_summary(cur, rest, masses, INV_DT)
    assert (fastest, bad) == (1, 2)
    assert speed == pytest.approx(0.5 * INV_DT) and energy == pytest.approx(0.5 * (0.5 * INV_DT) ** 2)


def test_motion_summary_huge_but_finite_particle_is_finite():
    # finiteness is tested per coordinate: a float32 sum of finite coordinates can overflow
    big = np.float32(2e38)
    cur = f32([[0, 0, 0, 1], [big, big, 0, 1]])
    prev = cur.copy()
    assert np.isfinite(cur).all() and np.isfinite(prev).all()
    want = ref.motion_summary(cur, prev, np.ones(2), INV_DT)
    assert want == (0.0, 0.0, 0, -1)
    assert motion_summary(cur, prev, np.ones(2), INV_DT) == want


def tether_layout(rng, n, k):
    """Slot s of particle i at s*n + i; pinned particles and some slots hold i with length 0."""
    pinned = rng.random(n) < 0.25
    pinned[0] = True
    anchors = np.tile(np.arange(n), k)
    lengths = np.zeros(k * n)
    free = np.flatnonzero(~pinned)
    for s in range(k):
        active = free[rng.random(free.size) < 0.8]
        anchors[s * n + active] = rng.choice(np.flatnonzero(pinned), active.size)
        lengths[s * n + active] = rng.uniform(0.3, 2.0, active.size)
    return anchors.astype(np.int32), f32(lengths)


@settings(max_examples=25)
@given(seed=seeds, n=st.integers(1, 40), k=st.integers(1, 3), stretch=st.booleans())
def test_tether_stretch_matches_reference(seed, n, k, stretch):
    rng = np.random.default_rng(seed)
    cur, _ = particles(rng, n)
    if not stretch:
        cur[:, :3] *= np.float32(0.05)  # every tether slack: the stretch is 0, not negative
    anchors, lengths = tether_layout(rng, n, k)
    got = tether_stretch(anchors, lengths, cur)
    want = ref.tether_stretch(anchors, lengths, cur)
    # the kernel takes p - anchor in float32 (within U relative per component), then float64:
    # the ratio |d| / length is within ~2U of exact, relative
    assert got == pytest.approx(want, abs=4 * U * (want + 1))
    if not stretch:
        assert got == 0.0


def test_tether_stretch_ignores_inactive_slots():
    cur = f32([[0, 0, 0, 0], [0, -3, 0, 1]])
    # slot 0: particle 1 hangs 3 from anchor 0 on a tether of 2 (50% stretch); slot 1: self
    # slots (anchor = particle) and a zero length, which must not count (3 / 0)
    anchors = np.array([0, 0, 0, 1], np.int32)
    lengths = f32([0, 2, 0, 0])
    assert tether_stretch(anchors, lengths, cur) == pytest.approx(0.5)
    assert ref.tether_stretch(anchors, lengths, cur) == pytest.approx(0.5)
    assert tether_stretch(np.zeros(0, np.int32), f32([]), cur) == 0.0
    assert ref.tether_stretch(np.zeros(0, np.int32), f32([]), cur) == 0.0


@settings(max_examples=60)
@given(seed=seeds, n=st.one_of(st.integers(0, 400), st.integers(400, 5000)),
       q=st.sampled_from([0.0, 1.0, 50.0, 90.0, 99.0, 99.9, 100.0]), ties=st.booleans())
def test_upper_percentile_matches_numpy(seed, n, q, ties):
    rng = np.random.default_rng(seed)
    values = f32(rng.normal(0.0, 0.05, n))
    if ties:  # many equal values, as strains of a cloth at rest are
        values = f32(np.round(values, 2))
    got = upper_percentile(values, q)
    want = ref.upper_percentile(values, q)
    if n == 0:
        assert np.isnan(got) and np.isnan(want)
    else:
        assert got == pytest.approx(want, rel=1e-12, abs=1e-15)


def test_upper_percentile_nan():
    assert np.isnan(upper_percentile(f32([0.1, np.nan, 0.2]), 99.0))
    assert upper_percentile(f32([0.25]), 99.0) == 0.25


def summary_of_one(indices, rest, spans, groups, q, cur, prev, masses, inv_dt, anchors, lengths, span_max, span_sum,
                   percentiles):
    """frame_summary of one cloth (one member owning everything); returns its motion row as
    (max speed, energy, fastest, first non-finite, tether stretch)."""
    motion = np.full((1, 5), np.nan)
    members = np.array([0, groups.shape[0] - 1], np.int64)
    frame_summary(indices, rest, spans, groups, members, np.array([0, cur.shape[0]], np.int64),
                  np.array([0, anchors.shape[0]], np.int64), q, cur, prev, masses, inv_dt, anchors, lengths, span_max,
                  span_sum, percentiles, motion)
    speed, energy, fastest, bad, stretch = motion[0].tolist()
    return speed, energy, int(fastest), int(bad), stretch


def groups_of(rng, spans):
    """Random group offsets over ``spans`` spans: 0 = g0 <= g1 <= ... = spans."""
    cuts = np.sort(rng.integers(0, spans + 1, rng.integers(0, 4)))
    return np.concatenate([[0], cuts, [spans]]).astype(np.int64)


@settings(max_examples=25)
@given(seed=seeds, n=st.integers(1, 40), c=st.integers(0, 80), spans=st.integers(0, 5), k=st.integers(0, 2),
       q=st.sampled_from([0.0, 50.0, 99.0, 100.0]), with_percentiles=st.booleans())
def test_frame_summary_is_the_separate_kernels_in_one_call(seed, n, c, spans, k, q, with_percentiles):
    """The same figures, to the bit, as strain_extremes over each span, motion_summary,
    tether_stretch and upper_percentile over each group's strains called one by one (which the
    reference checks against numpy)."""
    rng = np.random.default_rng(seed)
    cur, prev = particles(rng, n, speed=0.01)
    indices = np.ascontiguousarray(rng.integers(0, n, (c, 2)), np.int32)
    rest = f32(rng.uniform(0.0, 1.0, c))
    cuts = np.sort(rng.integers(0, c + 1, 2 * spans)).reshape(-1, 2).astype(np.int64)
    groups = groups_of(rng, spans)
    masses = rng.uniform(0.001, 0.01, n)
    anchors = np.ascontiguousarray(rng.integers(0, n, k * n), np.int32)
    lengths = f32(rng.uniform(0.0, 1.0, k * n))
    span_max, span_sum = np.full(spans, np.nan), np.full(spans, np.nan)
    percentiles = np.full(groups.shape[0] - 1 if with_percentiles else 0, -7.0)
    got = summary_of_one(indices, rest, cuts, groups, q, cur, prev, masses, INV_DT, anchors, lengths, span_max, span_sum,
                         percentiles)
    separate = (*motion_summary(cur, prev, masses, INV_DT), tether_stretch(anchors, lengths, cur))
    assert got == separate
    for s, (first, last) in enumerate(cuts):
        assert (span_max[s], span_sum[s]) == strain_extremes(indices[first:last], rest[first:last], cur)
    for g in range(percentiles.shape[0]):
        strains = np.concatenate([np.zeros(0, np.float32)] + [strain_of(indices[a:b], rest[a:b], cur) for a, b in cuts[groups[g] : groups[g + 1]]])
        assert percentiles[g] == upper_percentile(strains, q) or np.isnan(percentiles[g]) and strains.size == 0
    want_max, want_sum = np.full(spans, np.nan), np.full(spans, np.nan)
    want_percentiles = np.full_like(percentiles, -7.0)
    want = ref.frame_summary(indices, rest, cuts, groups, q, cur, prev, masses, INV_DT, anchors, lengths, want_max, want_sum,
                             want_percentiles)
    assert got[2:4] == want[2:4] and got[0] == pytest.approx(want[0], rel=1e-6) and got[4] == pytest.approx(want[4], rel=1e-5, abs=1e-5)
    for s, (first, last) in enumerate(cuts):
        if last > first:
            assert span_max[s] == pytest.approx(want_max[s], abs=10 * U * (abs(want_max[s]) + 1))
    assert_close(percentiles, want_percentiles, atol=10 * U * (np.abs(want_percentiles) + 1))


@settings(max_examples=20)
@given(seed=seeds, c=st.integers(300, 6000), spans=st.integers(1, 4), q=st.sampled_from([50.0, 90.0, 99.0, 99.9]),
       order=st.sampled_from(["random", "rising", "falling"]))
def test_frame_summary_percentiles_over_many_blocks(seed, c, spans, q, order):
    """Group percentiles over thousands of strains (the candidates are pruned many times),
    including strains that rise or fall along the constraints (each new one a candidate, or
    none after the first block), equal np.percentile over the group's strains."""
    rng = np.random.default_rng(seed)
    n = 200
    cur, prev = particles(rng, n, speed=0.01)
    indices = np.ascontiguousarray(rng.integers(0, n, (c, 2)), np.int32)
    rest = f32(rng.uniform(0.5, 1.5, c))
    if order != "random":  # sort the constraints by their strain
        strains = ref.constraint_strain(indices, rest, cur)
        ranks = np.argsort(strains if order == "rising" else -strains, kind="stable")
        indices, rest = np.ascontiguousarray(indices[ranks]), np.ascontiguousarray(rest[ranks])
    cuts = np.sort(np.concatenate([[0, c], rng.integers(0, c + 1, 2 * spans - 2)])).reshape(-1, 2).astype(np.int64)
    groups = np.array([0, spans], np.int64)
    span_max, span_sum, percentiles = np.zeros(spans), np.zeros(spans), np.zeros(1)
    summary_of_one(indices, rest, cuts, groups, q, cur, prev, np.ones(n), INV_DT, anchors := np.zeros(0, np.int32),
                   np.zeros(0, np.float32), span_max, span_sum, percentiles)
    strains = np.concatenate([strain_of(indices[a:b], rest[a:b], cur) for a, b in cuts])
    assert percentiles[0] == upper_percentile(strains, q)
    assert percentiles[0] == pytest.approx(np.percentile(strains.astype(np.float64), q), rel=1e-12, abs=1e-15)
    assert anchors.size == 0


def test_frame_summary_percentile_of_a_nan_strain_is_nan():
    cur, prev = particles(np.random.default_rng(0), 4, speed=0.01)
    cur[2, 0] = np.nan
    indices = np.array([[0, 1], [1, 2], [2, 3]], np.int32)
    percentiles = np.zeros(2)
    summary_of_one(indices, f32([1.0, 1.0, 1.0]), np.array([[0, 1], [1, 3]], np.int64), np.array([0, 1, 2], np.int64), 99.0,
                   cur, prev, np.ones(4), INV_DT, np.zeros(0, np.int32), np.zeros(0, np.float32), np.zeros(2), np.zeros(2),
                   percentiles)
    assert np.isfinite(percentiles[0]) and np.isnan(percentiles[1])


@settings(max_examples=15)
@given(seed=seeds, members=st.integers(1, 5), with_percentiles=st.booleans())
def test_frame_summary_of_members_is_each_members_own(seed, members, with_percentiles):
    """Several cloths in one call (a merged group's stats): each member's figures have the
    bits of its own call, its arrays concatenated with indices counting from its first
    particle, its particles rows of one state after some rows of no member."""
    rng = np.random.default_rng(seed)
    lead = int(rng.integers(0, 3))  # rows before the first member
    sizes = rng.integers(1, 30, members)
    cur, prev = particles(rng, lead + int(sizes.sum()), speed=0.01)
    masses = rng.uniform(0.001, 0.01, cur.shape[0])
    parts = []  # per member: indices, rest, spans, groups, anchors, lengths
    for n in sizes:
        c, spans, k = int(rng.integers(0, 60)), int(rng.integers(0, 4)), int(rng.integers(0, 3))
        parts.append((np.ascontiguousarray(rng.integers(0, n, (c, 2)), np.int32), f32(rng.uniform(0.0, 1.0, c)),
                      np.sort(rng.integers(0, c + 1, 2 * spans)).reshape(-1, 2).astype(np.int64), groups_of(rng, spans),
                      np.ascontiguousarray(rng.integers(0, n, k * n), np.int32), f32(rng.uniform(0.0, 1.0, k * n))))
    offsets = lambda counts: np.cumsum([0, *counts]).astype(np.int64)  # noqa: E731
    c_base, s_base = offsets(p[0].shape[0] for p in parts), offsets(p[2].shape[0] for p in parts)
    g_base = offsets(p[3].shape[0] - 1 for p in parts)
    spans = np.concatenate([np.zeros((0, 2), np.int64)] + [p[2] + c_base[j] for j, p in enumerate(parts)])
    groups = np.concatenate([p[3][:-1] + s_base[j] for j, p in enumerate(parts)] + [s_base[-1:]])
    span_max, span_sum = np.full(s_base[-1], np.nan), np.full(s_base[-1], np.nan)
    percentiles = np.full(g_base[-1] if with_percentiles else 0, np.nan)
    motion = np.full((members, 5), np.nan)
    frame_summary(np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]), spans, groups, g_base,
                  lead + offsets(sizes), offsets(p[4].shape[0] for p in parts), 99.0, cur, prev, masses, INV_DT,
                  np.concatenate([p[4] for p in parts]), np.concatenate([p[5] for p in parts]), span_max, span_sum,
                  percentiles, motion)
    first = lead + offsets(sizes)
    for j, (indices, rest, own_spans, own_groups, anchors, lengths) in enumerate(parts):
        rows = slice(first[j], first[j + 1])
        own_max, own_sum = np.full(own_spans.shape[0], np.nan), np.full(own_spans.shape[0], np.nan)
        own_percentiles = np.full(own_groups.shape[0] - 1 if with_percentiles else 0, np.nan)
        want = summary_of_one(indices, rest, own_spans, own_groups, 99.0, cur[rows], prev[rows], masses[rows], INV_DT, anchors,
                              lengths, own_max, own_sum, own_percentiles)
        speed, energy, fastest, bad, stretch = motion[j].tolist()
        assert (speed, energy, int(fastest), int(bad), stretch) == want
        np.testing.assert_array_equal(span_max[s_base[j] : s_base[j + 1]], own_max)
        np.testing.assert_array_equal(span_sum[s_base[j] : s_base[j + 1]], own_sum)
        if with_percentiles:
            np.testing.assert_array_equal(percentiles[g_base[j] : g_base[j + 1]], own_percentiles)


@settings(max_examples=40)
@given(seed=seeds, count=st.integers(1, 700), ties=st.booleans(), m=st.integers(1, 40))
def test_selection_helpers_match_reference(seed, count, ties, m):
    """The percentile's selection (_select), pruning (_prune), candidate offers (_offer_block)
    and interpolation (_top_percentile) against numpy sorts on random values."""
    from clothtool.solver.kernels.stats import _offer_block, _prune, _select, _top_percentile

    rng = np.random.default_rng(seed)
    values = rng.normal(0.0, 1.0, count)
    if ties:
        values = np.round(values, 1)
    k = int(rng.integers(0, count))
    selected = values.copy()
    _select(selected, count, k)
    want = values.copy()
    ref._select(want, count, k)
    assert selected[k] == want[k]
    assert (selected[:k] <= selected[k]).all() and (selected[k + 1 :] >= selected[k]).all()
    assert np.array_equal(np.sort(selected), np.sort(values))

    m = min(m, count)
    got_top, want_top = values.copy(), values.copy()
    assert _prune(got_top, count, m) == ref._prune(want_top, count, m)
    assert np.array_equal(np.sort(got_top[:m]), want_top[:m])

    position, lo, m = ref._percentile_rank(count, 99.0)
    assert _top_percentile(values.copy(), count, m, position, lo) == ref._top_percentile(values.copy(), count, m, position, lo)

    size = ref._candidates(m)
    got_buffer, want_buffer = np.zeros(size), np.zeros(size)
    block = f32(np.concatenate([values[:256], [np.nan]])) if count > 3 else f32(values)
    threshold = float(np.median(values))
    got = _offer_block(got_buffer, 0, threshold, m, block, block.shape[0])
    want = ref._offer_block(want_buffer, 0, threshold, m, block, block.shape[0])
    assert got[0] == want[0] and (got[1] == want[1] or np.isnan(got[1]) and np.isnan(want[1]))
    assert np.array_equal(np.sort(got_buffer[: got[0]]), np.sort(want_buffer[: want[0]]))
