"""solve_phases / solve_xpbd (serial and parallel) against tests/reference/fabric.py, and
each parallel kernel against its serial one bit for bit, whatever the thread count, on
untiled fabrics and on fabrics cooked in cache tiles (several tiles solved at once)."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.mesh.coloring import TripletScheduler
from clothtool.mesh.shapes import grid
from clothtool.solver.fabric_layers import phase_layers
from clothtool.solver.kernels.fabric import _slack_over, solve_phases, solve_phases_parallel, solve_xpbd, solve_xpbd_parallel
from tests.kernels._data import F32, U, assert_close, f32
from tests.reference import fabric as ref

ITERATIONS = 3
# Positions below ~1.5. A constraint update is ~15 float32 roundings of values below ~1.5;
# Gauss-Seidel is a contraction, so earlier roundings do not grow, and they mostly cancel over
# the ~10-30 constraints a particle takes per iteration: measured errors stay below ~1.5e-7
# (about 10% of this bound) after three iterations, against corrections of 1e-2 and more.
ATOL = 16 * U * 1.5


def limit(x):
    """A compression or stretch limit as the kernel's slack threshold 1 - 1/limit."""
    return 1.0 - 1.0 / x


# (stiffness k, multiplier m, compression term, stretch term) per phase
PHASE_PARAMS = f32(
    [
        [0.9, 0.0, limit(0.9), limit(1.1)],  # neutral multiplier: the limits are ignored
        [0.7, 0.6, limit(0.9), limit(1.05)],
        [1.0, 1.0, limit(0.8), limit(1.1)],  # m = 1: free within the limits, stiff beyond
        [0.5, 0.3, limit(1.0), limit(1.0)],
    ]
)


def schedule(phases, movable):
    """The cooker's layout: each phase's pairs scheduled into conflict-free sets."""
    indices, set_offsets, phase_set_offsets = [], [0], [0]
    for pairs in phases:
        sets = TripletScheduler(pairs, movable).sets()
        indices.append(pairs[sets.order])
        set_offsets.extend((sets.offsets[1:] + set_offsets[-1]).tolist())
        phase_set_offsets.append(phase_set_offsets[-1] + sets.set_count)
    indices = np.concatenate(indices) if indices else np.zeros((0, 2), np.int64)
    return (
        np.ascontiguousarray(indices, np.int32),
        np.asarray(set_offsets, np.int32),
        np.asarray(phase_set_offsets, np.int32),
    )


def random_fabric(rng, n, constraints, phase_count):
    """Random pairs over n particles split into phases and scheduled; rest lengths 0.8-1.2x the
    current distance (and some exactly 0); painted stiffness in [0.3, 1]; 20% pinned, and
    a few movable particles with cur.w zeroed (as a motion constraint leaves them)."""
    cur = np.empty((n, 4), np.float32)
    cur[:, :3] = rng.uniform(0.0, 1.0, (n, 3))
    movable = rng.random(n) >= 0.2
    cur[:, 3] = np.where(movable, rng.uniform(0.5, 2.0, n), 0.0)
    cur[movable & (rng.random(n) < 0.1), 3] = 0.0
    pairs = np.sort(rng.integers(0, n, (constraints, 2)), axis=1)
    pairs = np.unique(pairs[pairs[:, 0] != pairs[:, 1]], axis=0)
    rng.shuffle(pairs)
    phases = np.array_split(pairs, phase_count)
    indices, set_offsets, phase_set_offsets = schedule(phases, movable)
    p = cur[:, :3].astype(np.float64)
    rest = np.linalg.norm(p[indices[:, 1]] - p[indices[:, 0]], axis=1) * rng.uniform(0.8, 1.2, indices.shape[0])
    rest[rng.random(indices.shape[0]) < 0.1] = 0.0
    stiffness = f32(rng.uniform(0.3, 1.0, indices.shape[0]))
    params = np.ascontiguousarray(PHASE_PARAMS[rng.permutation(4)[:phase_count]])
    return (indices, f32(rest), stiffness, set_offsets, phase_set_offsets, params), cur


def iterate(kernel, args, cur, iterations=ITERATIONS):
    """Positions after each of ``iterations`` calls; args = (indices, rest, per-constraint
    stiffness or alpha~, set_offsets, phase_set_offsets, params), the layers as the fabric
    stage finds them."""
    cur = cur.copy()
    layers = phase_layers(args[0], args[3], args[4])
    out = []
    for _ in range(iterations):
        kernel(*args, *layers, cur)
        out.append(cur.copy())
    return out


def iterate_reference(args, cur, iterations=ITERATIONS):
    out = []
    for _ in range(iterations):
        cur = ref.solve_phases(*args, cur)
        out.append(cur)
    return out


@pytest.mark.parametrize("kernel", [solve_phases, solve_phases_parallel], ids=["serial", "parallel"])
@pytest.mark.parametrize("seed,n,constraints,phases", [(0, 30, 90, 1), (1, 60, 200, 2), (2, 80, 300, 4), (3, 5, 12, 3)])
def test_random_sets_match_reference(kernel, seed, n, constraints, phases):
    rng = np.random.default_rng(seed)
    args, cur = random_fabric(rng, n, constraints, phases)
    got = iterate(kernel, args, cur)
    want = iterate_reference(args, cur)
    for it, (g, w) in enumerate(zip(got, want)):
        assert_close(g, w, ATOL, f"iteration {it}")
    assert np.abs(got[0] - cur).max() > 1000 * ATOL  # real corrections happened
    np.testing.assert_array_equal(got[-1][:, 3], cur[:, 3])
    still = cur[:, 3] == 0
    np.testing.assert_array_equal(got[-1][still], cur[still])  # w = 0 never moves


def test_zero_rest_length_and_pinned_pairs():
    """A zero rest length never pulls (er = 0), even with the multiplier on; a pair of pinned
    particles is left alone (0 / (eps + 0 + 0) = 0, not NaN); a taut pair meets halfway."""
    cur = f32([[0, 0, 0, 1], [1, 0, 0, 1], [0, 1, 0, 0], [1, 1, 0, 0], [0, 2, 0, 1], [2, 2, 0, 1]])
    indices = np.array([[0, 1], [2, 3], [4, 5]], np.int32)
    rest = f32([0.0, 0.5, 1.0])
    args = (indices, rest, f32([1, 1, 1]), np.array([0, 3], np.int32), np.array([0, 1], np.int32))
    for params in (f32([[1, 0, 0, 0]]), f32([[1, 0.5, limit(0.9), limit(1.1)]])):
        got = iterate(solve_phases, args + (params,), cur, 1)[0]
        want = ref.solve_phases(*args, params, cur)
        assert_close(got, want, ATOL, "cur")
        np.testing.assert_array_equal(got[:4], cur[:4])
    got = iterate(solve_phases, args + (f32([[1, 0, 0, 0]]),), cur, 1)[0]
    assert_close(got[4:, 0], [0.5, 1.5], ATOL, "halfway")


def test_multiplier_limits():
    """m = 1 removes the error within [compression, stretch] and only the excess beyond."""
    cur = f32([[0, 0, 0, 1], [1.05, 0, 0, 1], [0, 1, 0, 1], [1.5, 1, 0, 1]])
    indices = np.array([[0, 1], [2, 3]], np.int32)
    args = (indices, f32([1, 1]), f32([1, 1]), np.array([0, 2], np.int32), np.array([0, 1], np.int32))
    params = f32([[1.0, 1.0, limit(0.9), limit(1.1)]])
    got = iterate(solve_phases, args + (params,), cur, 1)[0]
    want = ref.solve_phases(*args, params, cur)
    assert_close(got, want, ATOL, "cur")
    np.testing.assert_array_equal(got[:2], cur[:2])  # 5% stretch: inside the 10% limit
    # er = 1 - 1/1.5 = 1/3, minus 1 * (1 - 1/1.1): the pair closes 1.5 * that, split evenly
    er = (1 - 1 / 1.5) - (1 - 1 / 1.1)
    assert_close(got[3, 0] - got[2, 0], 1.5 * (1 - er), 4 * ATOL, "length")


def test_unscheduled_sets_are_refused_by_the_reference():
    cur = f32([[0, 0, 0, 1], [1, 0, 0, 1], [2, 0, 0, 1]])
    indices = np.array([[0, 1], [1, 2]], np.int32)  # particle 1 twice in one set
    with pytest.raises(ValueError, match="conflict-free"):
        ref.solve_phases(indices, f32([1, 1]), f32([1, 1]), np.array([0, 2]), np.array([0, 1]), f32([[1, 0, 0, 0]]), cur)


@pytest.fixture(scope="module")
def cooked():
    """A 30x30 cooked grid hanging from its top row (4 phases, sets of ~400 constraints),
    crumpled a little, with painted stiffness and some motion-pinned particles."""
    mesh = grid(30, 30, spacing=0.05)
    fabric = cook_fabric(mesh, CookOptions(pin_box=(-1, -0.01, -1, 10, 0.01, 1), tethers="none")).fabric
    rng = np.random.default_rng(11)
    n = fabric.rest_pos.shape[0]
    cur = np.empty((n, 4), np.float32)
    cur[:, :3] = fabric.rest_pos + f32(rng.normal(0.0, 0.01, (n, 3)))
    w = fabric.particle_inv_mass / fabric.particle_inv_mass.max()
    cur[:, 3] = np.where(rng.random(n) < 0.05, 0.0, w)
    stiffness = f32(rng.uniform(0.5, 1.0, fabric.constraint_rest_length.shape[0]))
    params = np.ascontiguousarray(PHASE_PARAMS[: fabric.phase_type.shape[0]])
    args = (
        fabric.constraint_indices, fabric.constraint_rest_length, stiffness,
        fabric.set_offsets, fabric.phase_set_offsets, params,
    )
    return args, cur


def test_cooked_grid_matches_reference(cooked):
    args, cur = cooked
    got = iterate(solve_phases, args, cur)
    want = iterate_reference(args, cur)
    for it, (g, w) in enumerate(zip(got, want)):
        assert_close(g, w, ATOL, f"iteration {it}")


def test_parallel_equals_serial_bit_for_bit(cooked):
    args, cur = cooked
    serial = iterate(solve_phases, args, cur, 5)
    parallel = iterate(solve_phases_parallel, args, cur, 5)
    for s, p in zip(serial, parallel):
        assert np.array_equal(s, p)


def test_parallel_is_independent_of_the_thread_count(cooked):
    args, cur = cooked
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba has a single thread here (NUMBA_NUM_THREADS=1)")
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = iterate(solve_phases_parallel, args, cur, 5)
        numba.set_num_threads(2)
        two = iterate(solve_phases_parallel, args, cur, 5)
    finally:
        numba.set_num_threads(before)
    serial = iterate(solve_phases, args, cur, 5)
    for a, b, s in zip(one, two, serial):
        assert np.array_equal(a, b)
        assert np.array_equal(a, s)


def random_compliance(rng, c, h=1.0 / 240.0):
    """alpha~ = compliance / h^2 from stiff (0) to soft (~5 w), as solver.fabric makes it."""
    compliance = rng.choice([0.0, 1e-7, 1e-6, 1e-5, 1e-4], c) * rng.uniform(0.5, 2.0, c)
    return f32(compliance / (h * h))


def xpbd_args(args, alpha_tilde):
    indices, rest, _, set_offsets, phase_set_offsets, params = args
    return indices, rest, alpha_tilde, set_offsets, phase_set_offsets, params


@pytest.mark.parametrize("kernel", [solve_xpbd, solve_xpbd_parallel], ids=["serial", "parallel"])
@pytest.mark.parametrize("seed,n,constraints,phases", [(20, 40, 120, 1), (21, 70, 250, 3), (22, 5, 12, 2)])
def test_xpbd_random_sets_match_reference(kernel, seed, n, constraints, phases):
    rng = np.random.default_rng(seed)
    args, cur = random_fabric(rng, n, constraints, phases)
    args = xpbd_args(args, random_compliance(rng, args[0].shape[0]))
    got = iterate(kernel, args, cur)
    want = [cur]
    for _ in range(ITERATIONS):
        want.append(ref.solve_xpbd(*args[:4], want[-1]))
    for it, (g, w) in enumerate(zip(got, want[1:])):
        assert_close(g, w, ATOL, f"iteration {it}")
    assert np.abs(got[0] - cur).max() > 1000 * ATOL
    still = cur[:, 3] == 0
    np.testing.assert_array_equal(got[-1][still], cur[still])


def test_xpbd_without_compliance_is_the_rigid_edge_update():
    """alpha~ = 0 is PBD with stiffness 1: the same as solve_phases with k = s = 1, m = 0."""
    rng = np.random.default_rng(23)
    args, cur = random_fabric(rng, 40, 120, 1)
    indices, rest, _, set_offsets, phase_set_offsets, params = args
    xpbd = iterate(solve_xpbd, (indices, rest, f32(np.zeros(rest.shape[0])), set_offsets, phase_set_offsets, params), cur, 1)[0]
    rigid = (indices, rest, f32(np.ones(rest.shape[0])), set_offsets, phase_set_offsets, f32([[1, 0, 0, 0]]))
    assert_close(xpbd, iterate(solve_phases, rigid, cur, 1)[0], ATOL, "cur")


def test_xpbd_parallel_equals_serial_bit_for_bit(cooked):
    (indices, rest, _, set_offsets, phase_set_offsets, params), cur = cooked
    alpha_tilde = random_compliance(np.random.default_rng(24), rest.shape[0])
    args = (indices, rest, alpha_tilde, set_offsets, phase_set_offsets, params)
    serial = iterate(solve_xpbd, args, cur, 5)
    if numba.config.NUMBA_NUM_THREADS < 2:
        runs = [iterate(solve_xpbd_parallel, args, cur, 5)]
    else:
        before = numba.get_num_threads()
        try:
            runs = []
            for threads in (1, 2):
                numba.set_num_threads(threads)
                runs.append(iterate(solve_xpbd_parallel, args, cur, 5))
        finally:
            numba.set_num_threads(before)
    for parallel in runs:
        for s, p in zip(serial, parallel):
            assert np.array_equal(s, p)


def test_no_phases_and_empty_sets():
    rng = np.random.default_rng(3)
    cur = f32(rng.uniform(0, 1, (4, 4)))
    none = (np.zeros((0, 2), np.int32), f32([]), f32([]), np.zeros(1, np.int32), np.zeros(1, np.int32), f32(np.zeros((0, 4))))
    for kernel in (solve_phases, solve_phases_parallel):
        np.testing.assert_array_equal(iterate(kernel, none, cur, 1)[0], cur)
    # a phase with one empty set
    empty_set = (none[0], none[1], none[2], np.zeros(2, np.int32), np.array([0, 1], np.int32), f32([[1, 0, 0, 0]]))
    for kernel in (solve_phases, solve_phases_parallel):
        np.testing.assert_array_equal(iterate(kernel, empty_set, cur, 1)[0], cur)
    for kernel in (solve_xpbd, solve_xpbd_parallel):
        for layout in (none, empty_set):
            np.testing.assert_array_equal(iterate(kernel, layout, cur, 1)[0], cur)


@pytest.mark.parametrize("kernel", [solve_phases, solve_phases_parallel], ids=["serial", "parallel"])
def test_float64_state_matches_reference(cooked, kernel):
    """The precision option's float64 state: the same kernels on <4 x double> rows, within
    float64 rounding of the reference."""
    args, cur = cooked
    cur64 = cur.astype(np.float64)
    got = iterate(kernel, args, cur64)
    want = iterate_reference(args, cur64)
    for it, (g, w) in enumerate(zip(got, want)):
        assert g.dtype == np.float64
        assert_close(g, w, 1e-12, f"iteration {it}")


def test_float64_slack_and_inverse_from_one_root_and_one_division():
    """_slack_over (the float64 correction's er and 1/d) against the reference in extended
    precision: er within float64 rounding of |h| (u = 2^-53 each for the root and the few
    products), 1/d within a few roundings; from edges 30% off their rest length to 1e-12 off,
    zero rest lengths, and denominators from FLT_EPSILON (two pinned ends) to large."""
    rng = np.random.default_rng(31)
    u = np.finfo(np.float64).eps / 2
    length = rng.uniform(0.001, 3.0, 400)
    off = rng.choice([0.3, 1e-3, 1e-6, 1e-9, 1e-12], 400) * rng.choice([-1.0, 1.0], 400)
    rest = f32(length * (1.0 + off))
    rest[::17] = 0.0
    length2 = length * length + 1e-30
    denominator = rng.choice([1.1920929e-07, 1.0, 3.7, 250.0], 400) * rng.uniform(1.0, 2.0, 400)
    for r, l2, d in zip(rest, length2, denominator):
        er, inverse = _slack_over(r, l2, d)
        want_er, want_inverse = ref._slack_over(np.longdouble(r), np.longdouble(l2), np.longdouble(d))
        assert abs(np.longdouble(er) - want_er) <= 2 * u + 6 * u * abs(want_er), (r, l2, d, er, want_er)
        assert abs(np.longdouble(inverse) - want_inverse) <= 4 * u * want_inverse, (d, inverse, want_inverse)
        if r == 0:
            assert er == 0.0


@pytest.mark.parametrize("kernel", [solve_xpbd, solve_xpbd_parallel], ids=["serial", "parallel"])
def test_xpbd_float64_state_matches_reference(cooked, kernel):
    """The XPBD kernels on float64 state (their own float64 arithmetic: one root and one
    division per constraint), within float64 rounding of the reference."""
    (indices, rest, _, set_offsets, phase_set_offsets, params), cur = cooked
    alpha_tilde = random_compliance(np.random.default_rng(25), rest.shape[0])
    args = (indices, rest, alpha_tilde, set_offsets, phase_set_offsets, params)
    got = iterate(kernel, args, cur.astype(np.float64))
    want = [cur.astype(np.float64)]
    for _ in range(ITERATIONS):
        want.append(ref.solve_xpbd(*args[:4], want[-1]))
    for it, (g, w) in enumerate(zip(got, want[1:])):
        assert g.dtype == np.float64
        assert_close(g, w, 1e-12, f"iteration {it}")
    assert np.abs(got[0] - cur).max() > 1e-3


@pytest.fixture(scope="module")
def cooked_tiles():
    """A 30x30 grid cooked in cache tiles of 128 particles (clothtool.cook.tiles), so that
    the kernels solve layers of several tiles at once; crumpled as ``cooked``."""
    from clothtool.cook import tiles

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(tiles, "TILE_PARTICLES", 128)
        fabric = cook_fabric(grid(30, 30, spacing=0.05), CookOptions(pin_box=(-1, -0.01, -1, 10, 0.01, 1), tethers="none")).fabric
    rng = np.random.default_rng(12)
    n = fabric.rest_pos.shape[0]
    cur = np.empty((n, 4), np.float32)
    cur[:, :3] = fabric.rest_pos + f32(rng.normal(0.0, 0.01, (n, 3)))
    cur[:, 3] = np.where(rng.random(n) < 0.05, 0.0, fabric.particle_inv_mass / fabric.particle_inv_mass.max())
    stiffness = f32(rng.uniform(0.5, 1.0, fabric.constraint_rest_length.shape[0]))
    params = np.ascontiguousarray(PHASE_PARAMS[fabric.phase_type - 1])  # each type its own parameters
    args = (fabric.constraint_indices, fabric.constraint_rest_length, stiffness, fabric.set_offsets, fabric.phase_set_offsets, params)
    layers, _ = phase_layers(*args[:1], *args[3:5])
    assert np.diff(layers).max() > 1  # some layer runs several tiles at once
    return args, cur


@pytest.mark.parametrize("mode", ["nvcloth", "xpbd"])
def test_tiles_match_reference_and_the_serial_bits_at_any_thread_count(cooked_tiles, mode):
    args, cur = cooked_tiles
    if mode == "xpbd":
        args = xpbd_args(args, random_compliance(np.random.default_rng(25), args[0].shape[0]))
        serial_kernel, parallel_kernel = solve_xpbd, solve_xpbd_parallel
        want = [cur]
        for _ in range(ITERATIONS):
            want.append(ref.solve_xpbd(*args[:4], want[-1]))
        want = want[1:]
    else:
        serial_kernel, parallel_kernel = solve_phases, solve_phases_parallel
        want = iterate_reference(args, cur)
    serial = iterate(serial_kernel, args, cur)
    for it, (g, w) in enumerate(zip(serial, want)):
        assert_close(g, w, ATOL, f"iteration {it}")
    thread_counts = (1, 2) if numba.config.NUMBA_NUM_THREADS >= 2 else (1,)
    before = numba.get_num_threads()
    try:
        for threads in thread_counts:
            numba.set_num_threads(threads)
            for s, p in zip(serial, iterate(parallel_kernel, args, cur)):
                assert np.array_equal(s, p), f"{threads} threads"
    finally:
        numba.set_num_threads(before)
