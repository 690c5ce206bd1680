"""collide kernels (contacts per primitive kind, friction, continuous collision, the particle
and virtual-particle kernels) against tests/reference/collide.py."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from clothtool.solver.kernels.collide import (
    _unit,
    capsule_contacts,
    collide_particles,
    collide_particles_parallel,
    collide_virtual,
    continuous_contact,
    convex_contacts,
    frame_motion,
    friction_correction,
    movable_weights,
    point_correction,
    share_out,
    sphere_contacts,
    weighted_point,
)
from tests.kernels._data import F32, assert_close, f32
from tests.kernels.test_collide_mesh import build_grid, random_mesh
from tests.reference import collide as ref
from tests.reference.collide_pose import pack_capsules, pack_spheres, pack_triangles, pose_points


def moving_frame() -> np.ndarray:
    frame = np.zeros((8, 3))
    frame[0:3] = Rotation.from_rotvec([0.05, -0.1, 0.02]).as_matrix()
    frame[3] = [0.2, 0.1, -0.1]
    frame[4:7] = Rotation.from_rotvec([0.06, -0.09, 0.025]).as_matrix()
    frame[7] = [0.21, 0.1, -0.09]
    return frame


def still_frame() -> np.ndarray:
    frame = np.zeros((8, 3))
    frame[0:3] = frame[4:7] = np.eye(3)
    return frame


def scene(rng, frame):
    """Two spheres, a tapered capsule, a box and a one-plane convex, a bumpy mesh, apart from
    each other and all moving a little over the iteration: the kernels' (shapes, mesh)."""
    start = f32([[0.3, 0.0, 0.0, 0.15], [-0.3, 0.1, 0.2, 0.1], [0.0, 0.3, -0.3, 0.12], [0.3, 0.25, -0.3, 0.06]])
    end = f32(start + np.hstack([rng.normal(0, 0.01, (4, 3)), rng.normal(0, 0.002, (4, 1))]))
    spheres = f32(pack_spheres(start, end, np.array([0, 1], np.int32), f32([[0.01, 0.5], [0.0, 0.2]])))
    capsules = f32(pack_capsules(start, end, np.array([[2, 3]], np.int32), f32([[0.005, 0.8]])))
    box = np.zeros((6, 4), np.float32)
    box[:, :3] = np.vstack([np.eye(3), -np.eye(3)])
    box[:, 3] = [-0.3, 0.3, -0.25, 0.55, -0.05, 0.5]  # x in [-0.55,-0.3], y in [0.05,0.3], z in [-0.5,-0.25]
    floor = f32([[0.0, 1.0, 0.0, -0.35]])
    planes = np.vstack([box, floor])
    offsets = np.array([0, 6, 7], np.int32)
    convex_data = f32([[0.01, 0.4, 0.003, 0.0, -0.002], [0.0, 0.6, 0.0, 0.001, 0.0]])
    world, triangles = random_mesh(rng, 5)
    world = f32(world * 0.6 + [0.0, -0.2, 0.0])
    world1 = f32(world + [0.004, 0.003, 0.0])
    params = f32(np.tile([0.015, 0.3], (triangles.shape[0], 1)))
    _, grid, _, ranges, _, cell_start, cell_items = build_grid(world, world1, triangles, f32(params[:, 0]), 400)
    local0 = f32(pose_points(world, world1, frame, 0.0, 0))
    local1 = f32(pose_points(world, world1, frame, 1.0, 1))
    data = f32(pack_triangles(local0, local1, triangles, params))
    return (spheres, capsules, planes, offsets, convex_data), (data, cell_start, cell_items, ranges, grid)


def test_unit_and_frame_motion_match_reference():
    np.testing.assert_allclose(_unit(F32(3), F32(0), F32(4)), ref._unit(3, 0, 4), atol=1e-7)
    assert _unit(F32(0), F32(0), F32(0)) == (0.0, 1.0, 0.0)
    frame = moving_frame()
    np.testing.assert_allclose(frame_motion(frame, 0.3, -0.2, 0.5), ref.frame_motion(frame, 0.3, -0.2, 0.5), atol=1e-6)
    np.testing.assert_allclose(frame_motion(still_frame(), 0.3, -0.2, 0.5), (0, 0, 0), atol=0)


@pytest.mark.parametrize("frame", [still_frame(), moving_frame()], ids=["still", "moving"])
def test_contacts_per_kind_match_reference(frame):
    rng = np.random.default_rng(0)
    (spheres, capsules, planes, offsets, convex_data), _ = scene(rng, frame)
    hits = np.zeros(3, int)
    centres = np.vstack([spheres[:, 4:7], capsules[:, 8:11], capsules[:, 12:15], [[-0.425, 0.175, -0.375]]])
    for i in range(400):
        p = f32(centres[i % 5] + rng.normal(0, 0.12, 3))
        for k, (kernel, reference, args) in enumerate([
            (sphere_contacts, ref.sphere_contacts, (spheres,)),
            (capsule_contacts, ref.capsule_contacts, (capsules,)),
            (convex_contacts, ref.convex_contacts, (planes, offsets, convex_data, frame)),
        ]):
            got, want = kernel(*p, *args), reference(*p, *args)
            assert got[0] == want[0], (kernel, p, got, want)
            assert_close(got[1:], want[1:], 3e-5, kernel.__name__)
            hits[k] += got[0] > 0
    assert (hits > 20).all(), hits


def test_friction_correction_is_coulomb():
    rng = np.random.default_rng(1)
    for _ in range(100):
        args = f32(rng.normal(0, 0.01, 13))
        args[12] = abs(args[12])
        np.testing.assert_allclose(friction_correction(*args), ref.friction_correction(*args), atol=1e-7)
    # push-out 1e-3 up; tangential slip 2e-3 along x: mu |push| = 5e-4 removes a quarter of it
    got = friction_correction(F32(2e-3), F32(0), F32(0), F32(0), F32(0), F32(0), F32(0), F32(1e-3), F32(0),
                              F32(0), F32(0), F32(0), F32(5e-4))
    np.testing.assert_allclose(got, (-5e-4, 0, 0), atol=1e-9)
    # a budget above the slip sticks it fully; the surface's own motion is followed
    got = friction_correction(F32(2e-3), F32(0), F32(0), F32(0), F32(0), F32(0), F32(0), F32(1e-3), F32(0),
                              F32(1e-3), F32(0), F32(0), F32(5e-3))
    np.testing.assert_allclose(got, (-1e-3, 0, 0), atol=1e-9)


def particles(rng, n, speed=0.01):
    prev = np.empty((n, 4), np.float32)
    prev[:, :3] = rng.uniform(-0.6, 0.6, (n, 3))
    prev[:, 3] = np.where(rng.random(n) < 0.1, 0.0, 1.0)
    cur = prev.copy()
    cur[:, :3] += rng.normal(0, speed, (n, 3))
    cur[rng.random(n) < 0.05, 3] = 0.0  # held by a motion constraint this iteration
    return cur, prev


@pytest.mark.parametrize("frame", [still_frame(), moving_frame()], ids=["still", "moving"])
def test_collide_particles_matches_reference(frame):
    rng = np.random.default_rng(2)
    shapes, mesh = scene(rng, frame)
    cur0, prev0 = particles(rng, 150)
    cur = cur0.copy()
    collide_particles(shapes, mesh, frame, prev0, False, F32(50.0), F32(1.0), cur)
    ref_cur, ref_prev = ref.collide_particles(shapes, mesh, frame, prev0, False, 50.0, 1.0, cur0)
    assert_close(cur, ref_cur, 5e-5, "cur")
    np.testing.assert_array_equal(prev0, ref_prev)  # prev is never written
    fixed = (prev0[:, 3] == 0) | (cur0[:, 3] == 0)
    np.testing.assert_array_equal(cur[fixed], cur0[fixed])  # pinned particles are not moved
    moved = np.linalg.norm(cur[:, :3] - cur0[:, :3], axis=1) > 1e-6
    assert moved.sum() > 15
    assert (cur[moved, 3] < cur0[moved, 3]).all()  # collision mass scale: heavier when pushed
    # deterministic and thread-count independent: the parallel kernel gives the same bits
    again = cur0.copy()
    collide_particles_parallel(shapes, mesh, frame, prev0, False, F32(50.0), F32(1.0), again)
    np.testing.assert_array_equal(again, cur)


def test_continuous_collision_matches_reference():
    """Fast particles through the spheres and the capsule: the same end positions as the
    reference's time-of-impact search."""
    rng = np.random.default_rng(3)
    shapes, mesh = scene(rng, still_frame())
    spheres, capsules = shapes[0], shapes[1]
    cur0, prev0 = particles(rng, 24)
    cur0[:, 3] = prev0[:, 3] = 1.0
    targets = np.vstack([spheres[:, 4:7], 0.5 * (capsules[:, 8:11] + capsules[:, 12:15])])
    # aim through the colliders' middles from 0.3 away, ending 0.3 beyond: discrete would miss
    for i in range(cur0.shape[0]):
        target = targets[i % targets.shape[0]] + rng.normal(0, 0.03, 3)
        direction = rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        prev0[i, :3] = target - 0.3 * direction
        cur0[i, :3] = target + 0.3 * direction
    moved = 0
    for i in range(cur0.shape[0]):
        got = continuous_contact(*cur0[i, :3], *prev0[i, :3], spheres, capsules)
        want = ref.continuous_contact(*cur0[i, :3], *prev0[i, :3], spheres, capsules)
        assert got[0] == want[0]
        assert_close(got[1:], want[1:], 1e-3, f"particle {i}")
        moved += got[0]
    assert moved > 16
    cur = cur0.copy()
    collide_particles(shapes, mesh, still_frame(), prev0, True, F32(0.0), F32(1.0), cur)
    ref_cur, _ = ref.collide_particles(shapes, mesh, still_frame(), prev0, True, 0.0, 1.0, cur0)
    assert_close(cur, ref_cur, 1e-3, "cur")


def test_collide_virtual_matches_reference():
    """Virtual particles of a small triangle soup, some corners pinned."""
    rng = np.random.default_rng(4)
    shapes, mesh = scene(rng, moving_frame())
    cur0, prev0 = particles(rng, 40, speed=0.005)
    triangles = rng.integers(0, 40, (30, 3)).astype(np.int32)
    weights = f32([[1 / 3, 1 / 3, 1 / 3], [2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]])
    virtual = np.hstack([np.repeat(triangles, 4, axis=0), np.tile(np.arange(4), 30)[:, None]]).astype(np.int32)
    for continuous in (False, True):
        cur = cur0.copy()
        collide_virtual(virtual, weights, shapes, mesh, moving_frame(), prev0, continuous, F32(20.0), F32(1.0), cur)
        ref_cur, _ = ref.collide_virtual(virtual, weights, shapes, mesh, moving_frame(), prev0, continuous, 20.0, 1.0, cur0)
        assert_close(cur, ref_cur, 1e-4, f"cur (continuous {continuous})")
        fixed = (prev0[:, 3] == 0) | (cur0[:, 3] == 0)
        np.testing.assert_array_equal(cur[fixed], cur0[fixed])
        assert np.abs(cur - cur0).max() > 1e-3


@pytest.mark.parametrize("frame", [still_frame(), moving_frame()], ids=["still", "moving"])
@pytest.mark.parametrize("continuous", [False, True])
def test_point_correction_matches_reference(frame, continuous):
    """The contact summary the implicit and explicit integrators read: slow and fast paths
    (0.3 per iteration crosses colliders whole) around every primitive kind."""
    rng = np.random.default_rng(5)
    shapes, mesh = scene(rng, frame)
    hits = moves = 0
    for speed in (0.01, 0.3):
        cur, prev = particles(rng, 120, speed)
        for i in range(cur.shape[0]):
            got = point_correction(*cur[i, :3], *prev[i, :3], shapes, mesh, frame, continuous)
            count, moved, push, shift, budget = ref.point_correction(cur[i, :3], prev[i, :3], shapes, mesh, frame, continuous)
            assert_close(np.array(got[1:4]), moved, 2e-4, f"move {i}")
            hits += count > 0
            moves += bool(np.any(moved))
            if np.any(moved):  # put exactly on the surface: a contact there is rounding's call
                assert_close(np.add(got[1:4], got[4:7]), moved + push, 2e-4, f"correction {i}")
                continue
            assert got[0] == count, (i, got, count)
            assert_close(np.array(got[4:10]), np.concatenate([push, shift]), 2e-4, f"push/shift {i}")
            assert_close(np.array([got[10]]), np.array([budget]), 2e-4, f"budget {i}")
    assert hits > 20
    assert (moves > 5) == continuous


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_triangle_point_and_movable_weights_match_reference(dtype):
    """The point of a triangle at given weights, the weights kept for the corners free at
    both ends of the iteration (a corner pinned in cur or prev gets 0), and a correction
    shared out through them."""
    rng = np.random.default_rng(7)
    for _ in range(40):
        cur = np.asarray(rng.normal(size=(5, 4)), dtype)
        prev = np.asarray(rng.normal(size=(5, 4)), dtype)
        cur[:, 3] = np.where(rng.random(5) < 0.3, 0.0, 1.0)
        prev[:, 3] = np.where(rng.random(5) < 0.3, 0.0, 1.0)
        a, b, c = (int(i) for i in rng.choice(5, 3, replace=False))
        wa, wb = (dtype(x) for x in rng.dirichlet([1.0, 1.0, 1.0])[:2])
        wc = dtype(1.0) - wa - wb
        assert_close(weighted_point(cur, a, b, c, wa, wb, wc), ref.weighted_point(cur, a, b, c, wa, wb, wc), 1e-6, "point")
        got = movable_weights(cur, prev, a, b, c, wa, wb, wc)
        want = ref.movable_weights(cur, prev, a, b, c, wa, wb, wc)
        assert got[:3] == pytest.approx(want[:3], abs=0.0) and got[3] == pytest.approx(want[3], rel=1e-6)
        if got[3] > 0:  # the correction shared out to the corners that move, capped or not
            correction = [dtype(x) for x in rng.normal(0.0, 0.01, 3)]
            scale, cap = dtype(rng.uniform(0.5, 1.0)), dtype(rng.choice([np.inf, 1.2]))
            moved = cur.copy()
            share_out(moved, a, b, c, *got, *correction, scale, cap)
            assert_close(moved, ref.share_out(cur, a, b, c, *got, *correction, scale, cap), 1e-6, "shared out")
