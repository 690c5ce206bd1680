"""The virtual-particle kernel's broad phase (clothtool.solver.kernels.collide_cull) changes
no bit: collide_virtual against the exhaustive loop it replaced (every row tested against
every collider), on tangled sheets with runs of points per triangle among spheres, capsules
(one moving fast), convexes and a mesh, continuous collision off and on, float32 and float64."""

from __future__ import annotations

import functools

import numba
import numpy as np
import pytest

from clothtool._jit import KERNEL_OPTIONS
from clothtool.solver.kernels import collide as collide_module
from clothtool.solver.kernels.collide import collide_virtual_for, friction_correction
from clothtool.solver.kernels.collide_cull import capsules_far, segment_distance, spheres_far
from tests.kernels.test_collide import moving_frame, scene
from tests.reference.collide_pose import pack_capsules, pack_spheres

_VARIANTS = {  # (meshes, convexes, continuous) -> the point_correction collide_virtual calls
    (False, False, False): "_spheres_only", (False, False, True): "_spheres_continuous",
    (False, True, False): "_with_convexes", (False, True, True): "_with_convexes_continuous",
    (True, False, False): "_with_meshes", (True, False, True): "_with_meshes_continuous",
    (True, True, False): "_with_both", (True, True, True): "point_correction",
}


@functools.lru_cache(maxsize=None)
def exhaustive_kernel(variant):
    """collide_virtual as it was before the broad phase: every row, in order, through
    ``variant`` (a point_correction of clothtool.solver.kernels.collide)."""
    zero_type = np.float32

    def collide_virtual(virtual, weights, shapes, mesh, frame, prev, continuous, mass_scale, meters_per_unit, cur):
        zero = zero_type(0.0)
        one = zero_type(1.0)
        for r in range(virtual.shape[0]):
            a = virtual[r, 0]
            b = virtual[r, 1]
            c = virtual[r, 2]
            wa = weights[virtual[r, 3], 0]
            wb = weights[virtual[r, 3], 1]
            wc = weights[virtual[r, 3], 2]
            ma = wa if prev[a, 3] > zero and cur[a, 3] > zero else zero
            mb = wb if prev[b, 3] > zero and cur[b, 3] > zero else zero
            mc = wc if prev[c, 3] > zero and cur[c, 3] > zero else zero
            norm = ma * ma + mb * mb + mc * mc
            if norm <= zero:
                continue
            px = wa * cur[a, 0] + wb * cur[b, 0] + wc * cur[c, 0]
            py = wa * cur[a, 1] + wb * cur[b, 1] + wc * cur[c, 1]
            pz = wa * cur[a, 2] + wb * cur[b, 2] + wc * cur[c, 2]
            qx = wa * prev[a, 0] + wb * prev[b, 0] + wc * prev[c, 0]
            qy = wa * prev[a, 1] + wb * prev[b, 1] + wc * prev[c, 1]
            qz = wa * prev[a, 2] + wb * prev[b, 2] + wc * prev[c, 2]
            result = variant(px, py, pz, qx, qy, qz, shapes, mesh, frame, continuous)
            count, mx, my, mz, dx, dy, dz, sx, sy, sz, budget = result
            if count == 0 and mx == zero and my == zero and mz == zero:
                continue
            cx = mx
            cy = my
            cz = mz
            scale = one
            if count > 0:
                fx, fy, fz = friction_correction(
                    px + mx + dx, py + my + dy, pz + mz + dz, qx, qy, qz, dx, dy, dz, sx, sy, sz, budget
                )
                cx += dx + fx
                cy += dy + fy
                cz += dz + fz
            if count > 0 and mass_scale > 0.0:
                square = (dx * dx + dy * dy + dz * dz) * meters_per_unit * meters_per_unit
                scale = one / (one + mass_scale * square)
            for particle, m in ((a, ma), (b, mb), (c, mc)):
                if m == zero:
                    continue
                share = m / norm
                cur[particle, 0] += cx * share
                cur[particle, 1] += cy * share
                cur[particle, 2] += cz * share
                cur[particle, 3] *= one + (scale - one) * m

    return numba.njit(**KERNEL_OPTIONS)(collide_virtual)


def tangled_sheets(rng, n=9, sheets=3):
    """(rest, cur, prev, triangles): ``sheets`` crumpled n x n sheets through [-0.6, 0.6]^3,
    each particle stepping about 1 cm (a few fast), some pinned."""
    u, v = np.meshgrid(np.linspace(-0.6, 0.6, n), np.linspace(-0.6, 0.6, n))
    index = np.arange(n * n).reshape(n, n)
    a, b, c, d = index[:-1, :-1].ravel(), index[:-1, 1:].ravel(), index[1:, 1:].ravel(), index[1:, :-1].ravel()
    quad = np.concatenate([np.stack([a, d, c], 1), np.stack([a, c, b], 1)])
    rest, triangles = [], []
    for s in range(sheets):
        flat = np.stack([u, 0.15 * np.sin(3 * u + s) * np.cos(2 * v), v], -1).reshape(-1, 3)
        rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        rest.append(flat @ rotation.T + rng.normal(0, 0.03, flat.shape))
        triangles.append(quad + s * n * n)
    rest = np.concatenate(rest)
    prev = np.empty((rest.shape[0], 4))
    prev[:, :3] = rest
    prev[:, 3] = np.where(rng.random(rest.shape[0]) < 0.05, 0.0, rng.uniform(0.5, 2.0, rest.shape[0]))
    cur = prev.copy()
    cur[:, :3] += rng.normal(0, 0.01, rest.shape)
    fast = rng.random(rest.shape[0]) < 0.05
    cur[fast, :3] += rng.normal(0, 0.15, (int(fast.sum()), 3))
    return rest, cur, prev, np.concatenate(triangles).astype(np.int32)


def shapes_of(rng, dtype, convexes_and_mesh):
    """Spheres and tapered capsules among the sheets, one capsule sweeping 0.25 through them in
    the iteration; with ``convexes_and_mesh`` the box, floor and bumpy mesh of test_collide."""
    start = np.array([
        [0.25, 0.0, 0.1, 0.12], [-0.3, 0.2, -0.2, 0.08],  # spheres
        [0.0, -0.4, 0.0, 0.07], [0.1, 0.3, 0.1, 0.05],  # a still capsule
        [-0.4, -0.3, 0.3, 0.06], [-0.4, 0.3, 0.35, 0.04],  # the fast one
    ])
    end = start.copy()
    end[:, :3] += rng.normal(0, 0.005, (6, 3))
    end[4:, 0] += 0.25
    spheres = pack_spheres(start, end, np.array([0, 1], np.int32), np.array([[0.01, 0.5], [0.005, 0.2]]))
    capsules = pack_capsules(start, end, np.array([[2, 3], [4, 5]], np.int32), np.array([[0.01, 0.8], [0.01, 0.3]]))
    if convexes_and_mesh:
        (_, _, planes, offsets, convex_data), mesh = scene(rng, moving_frame())
    else:
        planes, offsets, convex_data = np.zeros((0, 4)), np.zeros(1, np.int32), np.zeros((0, 5))
        mesh = (np.zeros((0, 32), np.float32), np.zeros(2, np.int32), np.zeros(1, np.int32), np.zeros((0, 6), np.int32),
                np.array([0, 0, 0, 1, 1, 1, 1], np.float32))
    as_real = lambda x: np.ascontiguousarray(x, dtype)  # noqa: E731  (the stage's records follow the state's precision)
    shapes = (as_real(spheres), as_real(capsules), as_real(planes), offsets, as_real(convex_data))
    mesh = (as_real(mesh[0]), mesh[1], mesh[2], mesh[3], as_real(mesh[4]))
    return shapes, mesh


def point_runs(rng, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rows i32 (v,4), weights (w,3)): a run of 1 to 36 rows per triangle (i, j, k, weight
    row), each with its own random barycentric weights strictly inside the triangle."""
    counts = rng.integers(1, 37, triangles.shape[0])
    rows = np.empty((counts.sum(), 4), np.int32)
    rows[:, :3] = np.repeat(triangles, counts, axis=0)
    rows[:, 3] = np.arange(rows.shape[0])
    weights = rng.uniform(0.05, 1.0, (rows.shape[0], 3))
    return rows, weights / weights.sum(axis=1, keepdims=True)


@pytest.mark.parametrize("dtype", [np.float32, np.float64], ids=["f32", "f64"])
@pytest.mark.parametrize("kinds", [(False, False), (True, True)], ids=["spheres_capsules", "all_kinds"])
@pytest.mark.parametrize("continuous", [False, True], ids=["discrete", "continuous"])
def test_broad_phase_gives_the_exhaustive_bits(dtype, kinds, continuous):
    rng = np.random.default_rng(11)
    meshes, convexes = kinds
    rest, cur0, prev, triangles = tangled_sheets(rng)
    rows, patterns = point_runs(np.random.default_rng(12), triangles)  # its own stream: the rest as before
    levels = np.bincount(np.unique(rows[:, :3], axis=0, return_counts=True)[1])
    assert levels.shape[0] > 9 and levels[1:].sum() > 100  # runs of several lengths, up to 36
    # the fabric's own virtual particles first (one row per triangle, shuffled), as the stage has them
    fabric = np.hstack([triangles[rng.permutation(triangles.shape[0])[:60]], np.zeros((60, 1), np.int32)])
    weights = np.vstack([[[0.5, 0.25, 0.25]], patterns]).astype(dtype)
    rows[:, 3] += 1
    virtual = np.ascontiguousarray(np.vstack([fabric, rows]), np.int32)
    shapes, mesh = shapes_of(rng, dtype, convexes)
    # both kinds of run: triangles whose corners are all 0.2 beyond every sphere's and capsule's
    # reach (the broad phase skips them) and triangles touching one
    corners = cur0[triangles, :3]
    spheres, capsules = shapes[0].astype(np.float64), shapes[1].astype(np.float64)
    gaps = [np.linalg.norm(corners - s[4:7], axis=-1) - s[7] for s in spheres]
    for c in capsules:
        axis = c[12:15] - c[8:11]
        t = np.clip((corners - c[8:11]) @ axis / (axis @ axis), 0.0, 1.0)
        gaps.append(np.linalg.norm(corners - c[8:11] - t[..., None] * axis, axis=-1) - max(c[11], c[15]))
    gap = np.min(gaps, axis=0)
    assert (gap.min(axis=1) > 0.2).sum() > 50 and (gap.min(axis=1) < 0).sum() > 20
    frame = moving_frame()
    kernel = collide_virtual_for(meshes, convexes, True)
    reference = exhaustive_kernel(getattr(collide_module, _VARIANTS[(meshes, convexes, True)]))
    cur, want = cur0.astype(dtype), cur0.astype(dtype)
    prev = prev.astype(dtype)
    mass_scale, meters = dtype(20.0), dtype(1.0)
    for iteration in range(4):  # the corrections of one call are the next one's tangle
        kernel(virtual, weights, shapes, mesh, frame, prev, continuous, mass_scale, meters, cur)
        reference(virtual, weights, shapes, mesh, frame, prev, continuous, mass_scale, meters, want)
        assert cur.tobytes() == want.tobytes(), f"iteration {iteration}: {np.abs(cur - want).max()}"
        np.testing.assert_array_equal(cur, want)
        moved = np.abs(want - cur0.astype(dtype))[:, :3].max(axis=1) > 0
        assert 15 <= moved.sum() < 0.6 * cur.shape[0], moved.sum()  # contacts, and particles left alone
        prev = cur.copy()
        cur[:, :3] += rng.normal(0, 0.01, (cur.shape[0], 3)).astype(dtype)
        want[:] = cur
        cur0 = cur.copy()


def test_far_tests_match_closed_forms():
    """spheres_far / capsules_far on balls placed at known distances from a collider's surface:
    far beyond the slack, near within it; swept tests cover the collider's whole motion."""
    sphere = np.array([[0.0, 0.0, 0.0, 0.5, 0.3, 0.0, 0.0, 0.5, 0.2]])  # radius 0.5, moving 0.3 along +x
    for gap in (2e-3, -1e-3):
        # beyond the end pose (+x): the same distance, discrete or swept
        assert spheres_far(0.3 + 0.6 + gap, 0.0, 0.0, 0.1, sphere, False) == (gap > 0)
        assert spheres_far(0.3 + 0.6 + gap, 0.0, 0.0, 0.1, sphere, True) == (gap > 0)
        # behind the start pose (-x): far from the end pose, but the sweep starts next to it
        assert spheres_far(-(0.6 + gap), 0.0, 0.0, 0.1, sphere, False)
        assert spheres_far(-(0.6 + gap), 0.0, 0.0, 0.1, sphere, True) == (gap > 0)
    # a tapered capsule along y from 0 to 1 (radii 0.2 and 0.1), its far end moving 0.4 along z
    capsule = np.array([[0, 0, 0, 0.2, 0, 1, 0, 0.1, 0, 0, 0, 0.2, 0, 1, 0.4, 0.1, 0.3]], np.float64)
    # (x, 0.5, 0.2) is at distance x from the end axis: reach 0.2 (the larger radius) + the ball's 0.2
    assert capsules_far(0.402, 0.5, 0.2, 0.2, capsule, False)
    assert not capsules_far(0.399, 0.5, 0.2, 0.2, capsule, False)
    # swept from (0, 0.5, -1): 1 from the start axis, 1.2 / sqrt(1.16) from the end one; the axis
    # moves at most 0.4, so it stays (d0 + d1 - 0.4) / 2 away; minus the reach and the tolerance
    point = (0.0, 0.5, -1.0)
    d0 = segment_distance(*point, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0)
    d1 = segment_distance(*point, 0.0, 0.0, 0.0, 0.0, 1.0, 0.4)
    np.testing.assert_allclose([d0, d1], [1.0, 1.2 / np.sqrt(1.16)], rtol=1e-12)
    room = 0.5 * (d0 + d1 - 0.4) - 0.2 - (1e-4 * 0.2 + 1e-9)
    assert capsules_far(*point, room - 2e-3, capsule, True)
    assert not capsules_far(*point, room + 1e-6, capsule, True)
    assert capsules_far(*point, room + 1e-6, capsule, False)  # the end pose alone is farther


def test_cull_kernels_match_reference():
    """Each broad-phase kernel against tests/reference/collide_cull.py on random balls."""
    from clothtool.solver.kernels.collide_cull import (
        boxes_miss,
        collider_boxes,
        convexes_far,
        impact_tolerance,
        mesh_far,
        run_end,
        triangle_ball,
        triangle_box,
    )
    from tests.reference import collide_cull as ref

    rng = np.random.default_rng(3)
    shapes, mesh = shapes_of(rng, np.float32, True)
    frame = moving_frame()
    virtual = np.array([[0, 1, 2, 0], [0, 1, 2, 1], [3, 4, 5, 0], [3, 4, 5, 1], [3, 4, 5, 2]], np.int32)
    assert [run_end(virtual, r) for r in (0, 1, 2, 4)] == [ref.run_end(virtual, r) for r in (0, 1, 2, 4)] == [2, 2, 5, 5]
    cur, prev = rng.normal(0, 0.3, (6, 4)).astype(np.float32), rng.normal(0, 0.3, (6, 4)).astype(np.float32)
    np.testing.assert_allclose(triangle_ball(cur, prev, 0, 1, 2), ref.triangle_ball(cur, prev, 0, 1, 2), rtol=1e-12)
    assert triangle_box(cur, prev, 0, 1, 2) == ref.triangle_box(cur, prev, 0, 1, 2)
    assert impact_tolerance(0.3) == ref.impact_tolerance(0.3) == pytest.approx(3.0001e-5)
    count = shapes[0].shape[0] + shapes[1].shape[0]
    for swept in (False, True):
        boxes, want = np.empty((count, 6)), np.empty((count, 6))
        collider_boxes(shapes[0], shapes[1], swept, boxes)
        ref.collider_boxes(shapes[0], shapes[1], swept, want)
        np.testing.assert_allclose(boxes, want, rtol=1e-12)
    misses = 0
    for _ in range(300):  # boxes placed at random, both verdicts
        lo = rng.uniform(-0.8, 0.6, 3)
        box = (*lo, *(lo + rng.uniform(0.0, 0.2, 3)))
        assert boxes_miss(*box, boxes) == ref.boxes_miss(*box, boxes)
        misses += ref.boxes_miss(*box, boxes)
    assert 20 < misses < 280, misses
    verdicts = np.zeros((4, 2), int)
    for _ in range(300):
        c, radius = rng.uniform(-0.7, 0.7, 3), float(rng.uniform(0.0, 0.15))
        for k, (got, want) in enumerate([
            (spheres_far(*c, radius, shapes[0], True), ref.spheres_far(*c, radius, shapes[0], True)),
            (capsules_far(*c, radius, shapes[1], True), ref.capsules_far(*c, radius, shapes[1], True)),
            (convexes_far(*c, radius, *shapes[2:]), ref.convexes_far(*c, radius, *shapes[2:])),
            (mesh_far(*c, radius, mesh[1], mesh[4], frame), ref.mesh_far(*c, radius, mesh[1], mesh[4], frame)),
        ]):
            assert got == want, (k, c, radius)
            verdicts[k, int(got)] += 1
    assert (verdicts >= 5).all(), verdicts  # both verdicts for every kind
