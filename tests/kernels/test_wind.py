"""apply_wind against tests/reference/wind.py (a sequential loop: the order matters)."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.mesh.coloring import TripletScheduler
from clothtool.mesh.shapes import grid
from clothtool.solver.kernels.wind import apply_wind
from tests.kernels._data import F32, U, assert_close, f32
from tests.reference import wind as ref

H = 1.0 / 240.0  # iteration length: 60 fps, 4 iterations
# Positions stay below ~1.5 and every particle takes <= 6 triangle impulses, each one rounding
# of a value below 1.5; the impulses themselves (~1e-2) carry the relative error of d, whose
# float32 cancellation (c_t - p_t with |c| ~ 1, |d| ~ 1e-2) is ~1e-5: another ~1e-7.
ATOL = 16 * U * 1.5
NO_FRAME = (np.zeros((3, 3), np.float32), np.zeros(3, np.float32))


def cloth(rng, columns=7, rows=6, spacing=0.2, speed=2.0, pinned=0.15):
    """A crumpled triangulated grid moving at about ``speed`` m/s, as (triangles, cur, prev)."""
    mesh = grid(columns, rows, spacing=spacing)
    triangles = mesh.face_vertex_indices.reshape(-1, 3).astype(np.int32)
    n = mesh.vertex_count
    prev = np.empty((n, 4), np.float32)
    prev[:, :3] = mesh.vertex_pos + rng.normal(0.0, 0.05, (n, 3))
    prev[:, 3] = np.where(rng.random(n) < pinned, 0.0, rng.uniform(0.5, 2.0, n))
    cur = prev.copy()
    velocity = rng.normal(0.0, speed, 3) + rng.normal(0.0, 0.3 * speed, (n, 3))
    cur[:, :3] += (velocity * H).astype(np.float32)
    return np.ascontiguousarray(triangles), cur, prev


def coefficients(rng, density=(2.0, 5.0)):
    """(drag, lift, density). Each impulse moves a particle by about drag * |d|^2 * a * density
    * w: with |d| ~ 1e-2, a ~ 0.04 and w ~ 1 that is ~10-30% of |d| for a density of about a
    thousand, far above ATOL yet well short of the over-correction (> 100%) at which
    repeated impulses blow up. (The kernel's density is rho s^3 / 12; these values stand for
    a heavy fluid so that the test exercises large pushes.)"""
    drag, lift = F32(rng.uniform(0.1, 0.6)), F32(rng.uniform(0.1, 0.6))
    return drag, lift, F32(rng.uniform(*density) / H)


def one_by_one(triangles):
    """Colour offsets with one triangle per colour: strictly the given order."""
    return np.arange(triangles.shape[0] + 1, dtype=np.int32)


def shares(n, seed=0):
    """Per-particle shares around 1, as a quad mesh's are (3/4 to 3/2)."""
    return f32(np.random.default_rng(1000 + seed).uniform(0.75, 1.5, n))


def run(triangles, frame, air, coeffs, cur, prev, offsets=None, share=None):
    out = cur.copy()
    offsets = one_by_one(triangles) if offsets is None else offsets
    share = shares(cur.shape[0]) if share is None else share
    apply_wind(triangles, offsets, share, frame[0], frame[1], air, *coeffs, out, prev)
    return out


def compare(triangles, frame, air, coeffs, cur, prev, offsets=None, share=None):
    share = shares(cur.shape[0]) if share is None else share
    got = run(triangles, frame, air, coeffs, cur, prev, offsets, share)
    offsets = one_by_one(triangles) if offsets is None else offsets
    want = ref.apply_wind(triangles, offsets, share, frame[0], frame[1], air, *coeffs, cur, prev)
    assert_close(got, want, ATOL, "cur")
    np.testing.assert_array_equal(got[:, 3], cur[:, 3])  # inverse masses are read, not written
    pinned = cur[:, 3] == 0
    np.testing.assert_array_equal(got[pinned], cur[pinned])
    return got, want


@pytest.mark.parametrize("seed", range(4))
def test_drag_and_lift_in_still_air(seed):
    rng = np.random.default_rng(seed)
    triangles, cur, prev = cloth(rng)
    got, _ = compare(triangles, NO_FRAME, f32(np.zeros(3)), coefficients(rng), cur, prev)
    assert np.abs(got - cur).max() > 1000 * ATOL  # the test exercises real impulses


@pytest.mark.parametrize("seed", range(4))
def test_wind_and_frame_motion(seed):
    rng = np.random.default_rng(100 + seed)
    triangles, cur, prev = cloth(rng, speed=0.5)
    air = f32(rng.normal(0.0, 5.0, 3) * H)  # wind velocity * dt, local space
    angle = rng.normal(0.0, 0.02, 3)
    x, y, z = angle
    matrix = f32([[0, -z, y], [z, 0, -x], [-y, x, 0]])  # a small rotation's displacement
    offset = f32(rng.normal(0.0, 1.0, 3) * H)
    compare(triangles, (matrix, offset), air, coefficients(rng), cur, prev)


@pytest.mark.parametrize("seed", range(3))
def test_shared_particles_make_the_order_matter(seed):
    """A random triangle soup over few particles: every particle is shared by many triangles,
    each of which sees the positions the earlier ones pushed."""
    rng = np.random.default_rng(200 + seed)
    n, t = 12, 60
    triangles = np.array([rng.choice(n, 3, replace=False) for _ in range(t)], np.int32)
    prev = np.empty((n, 4), np.float32)
    prev[:, :3] = rng.uniform(-0.3, 0.3, (n, 3))
    prev[:, 3] = rng.uniform(0.5, 2.0, n)
    cur = prev.copy()
    cur[:, :3] += f32(rng.normal(0.0, 2.0, (n, 3)) * H)
    coeffs = coefficients(rng, density=(0.5, 1.0))  # ~15 triangles push each particle
    air = f32([0.0, 0.0, 3.0 * H])
    forward, _ = compare(triangles, NO_FRAME, air, coeffs, cur, prev)
    backward, _ = compare(np.ascontiguousarray(triangles[::-1]), NO_FRAME, air, coeffs, cur, prev)
    assert np.abs(forward - backward).max() > 100 * ATOL


def test_slow_motion_still_feels_the_air():
    """No speed threshold: a patch creeping at 1e-3 m/s (|d|^2 ~ 1e-11, far below the seed's
    FLT_EPSILON cut-off) gets the law's push, quadratic in its speed: a patch ten times faster
    is pushed a hundred times further. In float64, where pushes of ~1e-10 do not vanish in
    the rounding of positions ~1."""
    rng = np.random.default_rng(5)
    triangles, _, prev32 = cloth(rng, columns=4, rows=4, pinned=0.0)
    prev = prev32.astype(np.float64)
    step = np.array([0.3, -0.2, 1.0]) * 1e-3 * H
    coeffs = coefficients(np.random.default_rng(6))
    pushes = []
    for scale in (1.0, 10.0):
        cur = prev.copy()
        cur[:, :3] += step * scale
        got = cur.copy()
        share = np.ones(cur.shape[0])
        apply_wind(triangles, one_by_one(triangles), share, np.zeros((3, 3)), np.zeros(3), np.zeros(3), *coeffs, got, prev)
        want = ref.apply_wind(triangles, one_by_one(triangles), share, np.zeros((3, 3)), np.zeros(3), np.zeros(3), *coeffs,
                              cur, prev)
        push = got[:, :3] - cur[:, :3]
        np.testing.assert_allclose(push, want[:, :3] - cur[:, :3], rtol=1e-5, atol=1e-6 * np.abs(push).max())
        assert np.all(push @ step < 0)  # against the motion
        pushes.append(np.abs(push).max())
    np.testing.assert_allclose(pushes[1] / pushes[0], 100.0, rtol=1e-2)  # later triangles see the pushes: ~0.2%


def test_degenerate_triangle_gets_no_impulse():
    cur = f32([[0, 0, 0, 1], [1, 0, 0, 1], [2, 0, 0, 1], [0, 1, 0, 1]])  # 0,1,2 collinear
    prev = cur.copy()
    prev[:, 2] -= F32(0.05)
    triangles = np.array([[0, 1, 2]], np.int32)
    got, _ = compare(triangles, NO_FRAME, f32(np.zeros(3)), coefficients(np.random.default_rng(0)), cur, prev)
    np.testing.assert_array_equal(got, cur)
    # the same motion on a proper triangle is pushed back against the motion (drag)
    triangles = np.array([[0, 1, 3]], np.int32)
    got, _ = compare(triangles, NO_FRAME, f32(np.zeros(3)), coefficients(np.random.default_rng(0)), cur, prev)
    assert np.all(got[[0, 1, 3], 2] < cur[[0, 1, 3], 2])


def test_empty_triangles():
    rng = np.random.default_rng(1)
    _, cur, prev = cloth(rng, columns=2, rows=2)
    got = run(np.zeros((0, 3), np.int32), NO_FRAME, f32(np.zeros(3)), coefficients(rng), cur, prev)
    np.testing.assert_array_equal(got, cur)


@pytest.mark.parametrize("seed", range(3))
def test_colours_solved_in_blocks_give_the_one_by_one_bits(seed):
    """Triangles in colours sharing no movable particle (pinned ones are shared), on a cloth
    large enough for several blocks per colour: the blocked passes give exactly the bits of
    solving the same order one triangle at a time, and match the reference."""
    rng = np.random.default_rng(300 + seed)
    triangles, cur, prev = cloth(rng, columns=40, rows=30, spacing=0.05)
    schedule = TripletScheduler(triangles, cur[:, 3] > 0).sets()  # as the wind stage schedules them
    offsets = schedule.offsets
    coloured = np.ascontiguousarray(triangles[schedule.order], np.int32)
    assert np.diff(offsets).max() > 128  # more than one block in a colour
    air = f32(rng.normal(0.0, 5.0, 3) * H)
    coeffs = coefficients(rng)
    blocked, _ = compare(coloured, NO_FRAME, air, coeffs, cur, prev, offsets)
    np.testing.assert_array_equal(blocked, run(coloured, NO_FRAME, air, coeffs, cur, prev))
    assert np.abs(blocked - cur).max() > 1000 * ATOL


def test_reference_refuses_colours_that_share_particles():
    triangles = np.array([[0, 1, 2], [2, 3, 4]], np.int32)
    rng = np.random.default_rng(2)
    _, cur, prev = cloth(rng, columns=3, rows=2)
    with pytest.raises(ValueError, match="share a movable particle"):
        ref.apply_wind(triangles, np.array([0, 2]), shares(cur.shape[0]), *NO_FRAME, f32(np.zeros(3)), *coefficients(rng),
                       cur, prev)
