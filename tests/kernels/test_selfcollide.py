"""transform_points / build_grid / collide_points against tests/reference/selfcollide.py
(the collision against brute force over all pairs; the neighbour list's rows against brute
force within distance + skin)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from clothtool.solver.kernels.selfcollide import (
    REBUILD_FRACTION,
    _displaced,
    _list_pairs,
    _list_rows,
    _runs_overlap,
    build_grid,
    collide_points,
    collide_points_parallel,
    transform_points,
)
from tests.kernels._data import F32, U, assert_close, f32
from tests.reference import selfcollide as ref

seeds = st.integers(0, 2**32 - 1)


def grid_buffers(m: int, buckets: int | None = None):
    """bucket_start, order, sorted_points, sorted_cell, strides for m points (B >= 2m
    buckets unless given)."""
    buckets = 1 << max(1, int(2 * m - 1).bit_length()) if buckets is None else buckets
    starts, order = np.zeros(buckets + 1, np.int32), np.zeros(m, np.int32)
    return starts, order, np.zeros((m, 4), np.float32), np.zeros((m, 3), np.int32), np.zeros(2, np.int64)


def scene(rng, own: int, others: int, spacing: float = 0.1, pinned: float = 0.2):
    """Own particles whose rest positions sit on a lattice of ``spacing`` (so rest distances
    are spacing * sqrt(integer)), neighbour points, all scattered in a box dense enough for
    many contacts; inverse masses in [0.5, 2], a fraction pinned (w = 0)."""
    m = own + others
    side = int(np.ceil(own ** (1 / 3))) + 2
    lattice = rng.choice(side**3, own, replace=False)
    rest = f32(np.stack(np.unravel_index(lattice, (side,) * 3), axis=1) * spacing)
    points = np.empty((m, 4), np.float32)
    extent = 0.12 * max(m, 1) ** (1 / 3)
    points[:, :3] = rng.uniform(-extent, extent, (m, 3))
    points[:, 3] = np.where(rng.random(m) < pinned, 0.0, rng.uniform(0.5, 2.0, m))
    segment = np.zeros(m, np.int32)
    segment[own:] = rng.integers(1, 3, others)
    return points, rest, segment


class Lists:
    """A neighbour list's buffers for m points, own of them particles (capacity >= m
    entries; 8 per point unless given), with the grid's, as the stage allocates them."""

    def __init__(self, m: int, own: int, capacity: int | None = None, buckets: int | None = None, dtype=np.float32):
        self.grid = grid_buffers(m, buckets)
        self.anchor = np.zeros((m, 4), dtype)
        self.row_start = np.zeros(own + 1, np.int32)
        self.row_split = np.zeros(own, np.int32)
        self.pairs = np.zeros(max(8 * m, 1) if capacity is None else capacity, np.int32)
        self.found = np.zeros((self.pairs.shape[0], 2), np.int32)
        self.list_state = np.zeros(2, np.int64)
        self.sums = np.zeros((own, 4), dtype)

    def run(self, kernel, points, rest, segment, distances, stiffness, skin, cur, inv_cell=None):
        """The kernel's arguments in order; returns whether it rebuilt the list."""
        inv_cell = F32(1.0 / (distances.max() + skin)) if inv_cell is None else inv_cell
        return kernel(
            points, self.anchor, F32(skin), inv_cell, *self.grid, rest, segment,
            distances, stiffness, self.row_start, self.row_split, self.pairs, self.found, self.list_state, self.sums,
            cur,
        )


def collide(kernel, points, rest, segment, distances, stiffness, inv_cell=None, reference=False, buckets=None,
            skin=0.0, capacity=None):
    """Collide with fresh buffers (cells as large as the largest distance + skin unless given);
    returns the own particles after the kernel (or the reference)."""
    own = rest.shape[0]
    cur = points[:own].copy()
    if reference:
        return ref.collide_points(points, None, skin, inv_cell, None, None, None, None, None, rest, segment, distances,
                                  stiffness, np.zeros(own + 1, np.int32), None, None, None, None, None, cur)
    lists = Lists(points.shape[0], own, capacity, buckets)
    assert lists.run(kernel, points, rest, segment, distances, stiffness, skin, cur, inv_cell)
    return cur


@settings(max_examples=30)
@given(seed=seeds, m=st.integers(0, 300), scale=st.sampled_from([0.05, 0.3, 2.0]))
def test_build_grid_matches_reference(seed, m, scale):
    rng = np.random.default_rng(seed)
    points = f32(np.concatenate([rng.normal(0.0, scale, (m, 3)), np.ones((m, 1))], axis=1))
    inv_cell = F32(rng.uniform(2.0, 20.0))
    grid = grid_buffers(m)
    build_grid(points, inv_cell, *grid)
    names = ("starts", "order", "points", "cell", "strides")
    for got, want, name in zip(grid, ref.build_grid(points, inv_cell, *grid), names):
        np.testing.assert_array_equal(got, want, err_msg=name)
    starts, order, sorted_points, cell, strides = grid
    # every point once, in the bucket of its cell's number
    assert sorted(order.tolist()) == list(range(m))
    np.testing.assert_array_equal(sorted_points, points[order])
    mask = starts.shape[0] - 2
    for b in range(starts.shape[0] - 1):
        for k in range(starts[b], starts[b + 1]):
            assert ref._bucket(*cell[k], strides, mask) == b
    # rows hold the points' cells along x and two more: x - 1 of the first cell and x + 1 of
    # the last never stand for a cell of the row next to them
    if m:
        assert strides[0] == cell[:, 0].max() - cell[:, 0].min() + 3
        assert strides[1] == strides[0] * (cell[:, 1].max() - cell[:, 1].min() + 3)


def test_build_grid_survives_nonfinite_and_huge_coordinates():
    points = f32([[np.nan, 0, 0, 1], [np.inf, -np.inf, 0, 1], [3e38, -3e38, 1e20, 1], [0, 0, 0, 1]])
    starts, order, sorted_points, sorted_cell, strides = grid = grid_buffers(4)
    build_grid(points, F32(100.0), *grid)
    assert strides[0] == 10**9 + 3  # x from 0 to inf (cell 1e9); NaN takes no part
    cell = np.empty_like(sorted_cell)
    cell[order] = sorted_cell
    np.testing.assert_array_equal(cell[0], [-1e9, 0, 0])
    np.testing.assert_array_equal(cell[1], [1e9, -1e9, 0])
    np.testing.assert_array_equal(cell[2], [1e9, -1e9, 1e9])
    assert sorted(order.tolist()) == [0, 1, 2, 3]
    # and colliding them neither crashes nor moves the finite particle
    rest = f32(np.arange(4)[:, None] * np.full((4, 3), 10.0))
    cur = collide(collide_points, points, rest, np.zeros(4, np.int32), f32([0.1]), F32(1.0))
    np.testing.assert_array_equal(cur[3], points[3])


def random_distances(rng, spacing: float, self_on: bool = True) -> np.ndarray:
    """Segment distances: own pairs' away from the lattice's rest distances spacing * sqrt(k),
    so float32 and float64 agree on the rest filter; segment 2 keeps nothing."""
    d_self = spacing * np.sqrt(rng.integers(1, 5) + 0.5)
    return f32([d_self if self_on else 0.0, rng.uniform(0.05, 0.25), 0.0])


@settings(max_examples=25)
@given(seed=seeds, own=st.integers(0, 120), others=st.integers(0, 80), self_on=st.booleans(),
       skin=st.sampled_from([0.0, 0.02, 0.1]), fits=st.booleans())
def test_collide_matches_brute_force(seed, own, others, self_on, skin, fits):
    """Either kernel, any skin, with a list that fits or one worked through in chunks."""
    rng = np.random.default_rng(seed)
    spacing = 0.1
    points, rest, segment = scene(rng, own, others, spacing)
    distances = random_distances(rng, spacing, self_on)
    stiffness = F32(rng.uniform(0.2, 1.0))
    capacity = None if fits else max(own + others, 1)
    want = collide(None, points, rest, segment, distances, stiffness, reference=True)
    for kernel in (collide_points, collide_points_parallel):
        got = collide(kernel, points, rest, segment, distances, stiffness, skin=skin, capacity=capacity)
        # corrections below ~0.25 built from ~30 roundings each
        assert_close(got, want, 64 * U * 0.25 + 4 * U * 1.0, "cur")
        moved = np.any(got != points[:own], axis=1)
        assert not moved[points[:own, 3] == 0].any(), "a pinned particle moved"
        if own > 30 and others > 30:
            assert moved.any(), "the setup should produce contacts"


@settings(max_examples=20)
@given(seed=seeds, own=st.integers(1, 150), others=st.integers(0, 60), skin=st.sampled_from([0.0, 0.03, 0.1]),
       buckets=st.sampled_from([None, 4, 16]))
def test_list_pairs_and_list_rows_match_brute_force(seed, own, others, skin, buckets):
    """Every row ascending, the points within distance + skin (rest filter on own pairs),
    row_split at its first entry above the row, whether built at once from the pairs found
    once each (_list_pairs) or row by row; a buffer too small for all rows takes as many
    whole rows as fit (and _list_pairs only reports the entries needed), and the next call
    goes on from the first row left out."""
    rng = np.random.default_rng(seed)
    spacing = 0.1
    points, rest, segment = scene(rng, own, others, spacing)
    distances = random_distances(rng, spacing)
    m = own + others
    inv_cell = F32(1.0 / (distances.max() + skin))
    everything = sum(ref._row(i, points, skin, rest, segment, distances, own).size for i in range(own))
    for capacity in (8 * m, m):
        lists = Lists(m, own, capacity, buckets)
        build_grid(points, inv_cell, *lists.grid)
        grid_args = (*lists.grid, rest, segment, distances)
        at_once = (F32(skin), *grid_args, lists.row_start, lists.row_split, lists.pairs, lists.found)
        want = ref._list_pairs(*at_once)
        assert _list_pairs(*at_once) == want[0] == everything
        if everything <= capacity:
            for got, expected in zip((lists.row_start, lists.row_split, lists.pairs[:everything]),
                                     (want[1], want[2], want[3][:everything])):
                np.testing.assert_array_equal(got, expected)
        first, listed = 0, []
        while first < own:
            args = (points, inv_cell, F32(skin), *grid_args, lists.row_start, lists.row_split, lists.pairs)
            end = _list_rows(first, *args)
            want_end, want_start, want_split, want_pairs = ref._list_rows(first, *args)
            assert end == want_end and end > first
            np.testing.assert_array_equal(lists.row_start[first : end + 1], want_start[first : end + 1])
            np.testing.assert_array_equal(lists.row_split[first:end], want_split[first:end])
            np.testing.assert_array_equal(lists.pairs[: lists.row_start[end]], want_pairs[: want_start[end]])
            listed += [lists.pairs[lists.row_start[i] : lists.row_start[i + 1]].copy() for i in range(first, end)]
            first = end
        for i, row in enumerate(listed):
            np.testing.assert_array_equal(row, ref._row(i, points, skin, rest, segment, distances, own))


@settings(max_examples=50)
@given(log_buckets=st.integers(1, 20), width=st.integers(3, 5000), height=st.integers(3, 5000))
def test_runs_overlap_matches_reference(log_buckets, width, height):
    strides = np.array([width, width * height], np.int64)
    mask = 2**log_buckets - 1
    assert bool(_runs_overlap(strides, np.int64(mask))) == ref._runs_overlap(strides, mask)


def test_runs_overlap_on_known_grids():
    """Fewer than 8 buckets always overlap; a grid that fits in the buckets never does; rows
    of 2 cells would make x + 1 of one row x - 1 of the next."""
    assert _runs_overlap(np.array([10, 100], np.int64), np.int64(3))
    assert not _runs_overlap(np.array([10, 100], np.int64), np.int64(1023))
    assert _runs_overlap(np.array([2, 4], np.int64), np.int64(1023))
    assert _runs_overlap(np.array([10, 1024], np.int64), np.int64(1023))  # layers on top of each other


@settings(max_examples=30)
@given(seed=seeds, m=st.integers(0, 50), spread=st.floats(0.0, 0.2))
def test_displaced_matches_reference(seed, m, spread):
    rng = np.random.default_rng(seed)
    anchor = f32(rng.normal(size=(m, 4)))
    points = anchor.copy()
    points[:, :3] += f32(spread * rng.normal(size=(m, 3)))
    limit = F32(rng.uniform(0.05, 0.3))
    assert _displaced(points, anchor, limit) == ref._displaced(points, anchor, limit)
    if m:
        points[m // 2, 2] = np.nan
        assert _displaced(points, anchor, F32(1e9)) and ref._displaced(points, anchor, 1e9)


@settings(max_examples=10)
@given(seed=seeds)
def test_a_kept_list_gives_the_bits_of_a_fresh_one(seed):
    """Points that moved less than REBUILD_FRACTION of the skin keep the list (no rebuild)
    and the result is bit for bit that of a list built from where they are now (rows are
    sorted, so the pairs meet in one order whenever the list was built); one point moved a
    little farther rebuilds it."""
    rng = np.random.default_rng(seed)
    points, rest, segment = scene(rng, 300, 100)
    distances, skin = f32([0.15, 0.2, 0.1]), 0.05
    for kernel in (collide_points, collide_points_parallel):
        lists = Lists(400, 300)
        assert lists.run(kernel, points, rest, segment, distances, F32(0.7), skin, points[:300].copy())
        step = rng.normal(size=(400, 3))
        step *= (rng.uniform(0.0, 0.98, 400) * float(REBUILD_FRACTION) * skin / np.linalg.norm(step, axis=1))[:, None]
        moved = points.copy()
        moved[:, :3] += step
        kept = moved[:300].copy()
        assert not lists.run(kernel, moved, rest, segment, distances, F32(0.7), skin, kept)
        fresh = collide(kernel, moved, rest, segment, distances, F32(0.7), skin=skin)
        np.testing.assert_array_equal(kept, fresh)
        assert_close(kept, collide(None, moved, rest, segment, distances, F32(0.7), reference=True),
                     64 * U * 0.25 + 4 * U * 1.0, "kept list")
        assert np.any(kept != moved[:300])
        moved[7, 0] = lists.anchor[7, 0] + 0.5 * skin
        assert lists.run(kernel, moved, rest, segment, distances, F32(0.7), skin, moved[:300].copy())


def test_a_list_too_big_for_its_buffer_is_worked_through_in_chunks():
    """The same bits as with a buffer that fits; the list is marked incomplete (so the next
    call rebuilds it, moved or not) with the entries it needed, which the fitting list used."""
    rng = np.random.default_rng(5)
    points, rest, segment = scene(rng, 300, 100)
    distances, skin = f32([0.15, 0.2, 0.1]), 0.05
    for kernel in (collide_points, collide_points_parallel):
        roomy, tight = Lists(400, 300), Lists(400, 300, capacity=400)
        want, got = points[:300].copy(), points[:300].copy()
        roomy.run(kernel, points, rest, segment, distances, F32(0.7), skin, want)
        tight.run(kernel, points, rest, segment, distances, F32(0.7), skin, got)
        np.testing.assert_array_equal(got, want)
        assert roomy.list_state.tolist() == [1, roomy.row_start[-1]]
        assert tight.list_state.tolist() == [0, roomy.row_start[-1]] and roomy.row_start[-1] > 400
        assert tight.run(kernel, points, rest, segment, distances, F32(0.7), skin, points[:300].copy())


@settings(max_examples=15)
@given(seed=seeds, buckets=st.sampled_from([2, 4, 8, 16]))
def test_collide_with_crowded_buckets_matches_brute_force(seed, buckets):
    """So few buckets that a query's runs of cells share buckets: the kernel must then tell
    the cells apart and count no point twice (with many buckets it skips that test)."""
    rng = np.random.default_rng(seed)
    points, rest, segment = scene(rng, 150, 60)
    distances = f32([0.15, 0.2, 0.1])
    want = collide(None, points, rest, segment, distances, F32(0.8), reference=True, buckets=buckets)
    for kernel in (collide_points, collide_points_parallel):
        got = collide(kernel, points, rest, segment, distances, F32(0.8), buckets=buckets)
        assert_close(got, want, 64 * U * 0.25 + 4 * U * 1.0, "cur")
        assert np.any(got != points[:150])


@settings(max_examples=10)
@given(seed=seeds)
def test_serial_and_parallel_give_the_same_bits(seed):
    rng = np.random.default_rng(seed)
    points, rest, segment = scene(rng, 400, 200)
    distances = f32([0.15, 0.2, 0.1])
    for skin, capacity in ((0.05, None), (0.0, 600)):
        serial = collide(collide_points, points, rest, segment, distances, F32(0.7), skin=skin, capacity=capacity)
        parallel = collide(collide_points_parallel, points, rest, segment, distances, F32(0.7), skin=skin,
                           capacity=capacity)
        np.testing.assert_array_equal(serial, parallel)
        assert np.any(serial != points[:400])


def test_a_pair_is_pushed_to_the_distance_by_inverse_mass():
    """Two particles D/2 apart: with equal masses each moves D/4; with one pinned the other
    moves the whole D/2; particles that were closer than D at rest are left alone."""
    d = 0.1
    rest_far = f32([[0, 0, 0], [1, 0, 0]])
    points = f32([[0, 0, 0, 1], [0.05, 0, 0, 1]])
    segment = np.zeros(2, np.int32)
    got = collide(collide_points, points, rest_far, segment, f32([d]), F32(1.0))
    assert_close(got[:, :3], [[-0.025, 0, 0], [0.075, 0, 0]], 8 * U, "equal masses")
    points[0, 3] = 0.0
    got = collide(collide_points, points, rest_far, segment, f32([d]), F32(1.0))
    assert_close(got[:, :3], [[0, 0, 0], [0.1, 0, 0]], 8 * U, "one pinned")
    points[0, 3] = 1.0
    got = collide(collide_points, points, rest_far, segment, f32([d]), F32(0.5))
    assert_close(got[:, 0], [-0.0125, 0.0625], 8 * U, "half stiffness")
    rest_near = f32([[0, 0, 0], [0.09, 0, 0]])
    got = collide(collide_points, points, rest_near, segment, f32([d]), F32(1.0))
    np.testing.assert_array_equal(got, points)


def test_neighbour_points_push_only_own_particles():
    """A neighbour's point (segment 1) pushes an own particle by its share; the neighbour
    point itself is not in cur and so cannot move; coincident points are skipped."""
    points = f32([[0, 0, 0, 1], [5, 5, 5, 1], [0.02, 0, 0, 3], [5, 5, 5, 1]])
    rest = f32([[0, 0, 0], [9, 9, 9]])
    segment = np.array([0, 0, 1, 1], np.int32)
    got = collide(collide_points, points, rest, segment, f32([0.0, 0.1]), F32(1.0))
    assert_close(got[0, :3], [-0.08 * 0.25, 0, 0], 8 * U, "share 1/(1+3)")
    np.testing.assert_array_equal(got[1], points[1])  # coincident with neighbour point 3


def test_transform_points_matches_reference():
    rng = np.random.default_rng(3)
    src = f32(rng.normal(size=(50, 4)))
    angle = 0.7
    matrix = f32([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
    offset = f32([0.5, -1.0, 2.0])
    for w_scale in (F32(1.0), F32(0.0)):
        dst = np.zeros_like(src)
        transform_points(src, matrix, offset, w_scale, dst)
        assert_close(dst, ref.transform_points(src, matrix, offset, w_scale), 16 * U * 4, "dst")


def test_neighbour_cells_across_the_last_bucket():
    """Two points in cells x = 511 and x = 512 (rows of 4 cells) with 512 buckets, where the
    runs of a query share no bucket: a run of cells 510..512 of row 0 is buckets 510, 511
    and 0, so it wraps around; the pair must still be found, once, and pushed apart."""
    cell = 1.0 / 512  # cells as large as the distance (no skin)
    distances = f32([cell])
    points = f32([[511.9 * cell, 0.5 * cell, 0.5 * cell, 1.0], [512.1 * cell, 0.5 * cell, 0.5 * cell, 1.0]])
    rest = f32([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])  # far apart at rest: the pair counts
    segment = np.zeros(2, np.int32)
    strides = ref.grid_strides(points, 1.0 / cell)
    assert strides == (4, 12) and not ref._runs_overlap(strides, 511)
    assert ref._bucket(511, 0, 0, strides, 511) == 511 and ref._bucket(512, 0, 0, strides, 511) == 0
    for kernel in (collide_points, collide_points_parallel):
        got = collide(kernel, points, rest, segment, distances, F32(1.0), buckets=512)
        want = collide(None, points, rest, segment, distances, F32(1.0), reference=True)
        assert_close(got, want, 8 * U, "positions")
        assert abs((got[1, 0] - got[0, 0]) - cell) < 1e-6  # pushed out to the distance, half each
