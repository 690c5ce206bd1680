"""collide_pose kernels (interpolation into the cloth's frame, packed records) against
tests/reference/collide_pose.py."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from clothtool.solver.kernels.collide_pose import (
    convex_shift,
    convex_translation,
    pack_capsules,
    pack_spheres,
    pack_triangle,
    pack_triangles,
    pose_planes,
    pose_points,
    pose_spheres,
)
from tests.kernels._data import assert_close, f32
from tests.reference import collide_pose as ref


def random_frame(rng) -> np.ndarray:
    frame = np.zeros((8, 3))
    for end in (0, 1):
        frame[4 * end: 4 * end + 3] = Rotation.random(random_state=rng.integers(1 << 30)).as_matrix()
        frame[4 * end + 3] = rng.uniform(-2, 2, 3)
    return frame


def random_planes(rng, n):
    planes = np.empty((n, 4), np.float32)
    normal = rng.normal(size=(n, 3))
    planes[:, :3] = normal / np.linalg.norm(normal, axis=1, keepdims=True)
    planes[:, 3] = rng.uniform(-1, 1, n)
    return planes


@pytest.mark.parametrize("seed", range(3))
def test_pose_kernels_match_reference(seed):
    rng = np.random.default_rng(seed)
    frame = random_frame(rng)
    alpha = float(rng.uniform())
    points0, points1 = f32(rng.uniform(-1, 1, (20, 3))), f32(rng.uniform(-1, 1, (20, 3)))
    spheres0, spheres1 = f32(rng.uniform(0, 1, (6, 4))), f32(rng.uniform(0, 1, (6, 4)))
    planes0, planes1 = random_planes(rng, 5), random_planes(rng, 5)
    for end in (0, 1):
        out = np.empty_like(points0)
        pose_points(points0, points1, frame, alpha, end, out)
        assert_close(out, ref.pose_points(points0, points1, frame, alpha, end), 5e-6, "pose_points")
        out = np.empty_like(spheres0)
        pose_spheres(spheres0, spheres1, frame, alpha, end, out)
        assert_close(out, ref.pose_spheres(spheres0, spheres1, frame, alpha, end), 5e-6, "pose_spheres")
        out = np.empty_like(planes0)
        pose_planes(planes0, planes1, frame, alpha, end, out)
        assert_close(out, ref.pose_planes(planes0, planes1, frame, alpha, end), 5e-6, "pose_planes")


def test_posed_plane_holds_the_posed_points_of_the_world_plane():
    """A world point on the (interpolated) world plane, taken into the frame, lies on the
    local plane: the plane transform is the point transform's dual."""
    rng = np.random.default_rng(7)
    frame = random_frame(rng)
    plane = random_planes(rng, 1)
    out = np.empty_like(plane)
    pose_planes(plane, plane, frame, 0.0, 1, out)
    n, d = plane[0, :3].astype(np.float64), float(plane[0, 3])
    tangent = np.cross(n, rng.normal(size=3))
    world = f32([n * d + tangent, n * d - 2 * tangent, n * (d + 0.3)])
    local = np.empty_like(world)
    pose_points(world, world, frame, 0.0, 1, local)
    heights = local.astype(np.float64) @ out[0, :3] - out[0, 3]
    np.testing.assert_allclose(heights, [0.0, 0.0, 0.3], atol=1e-5)


def test_pack_records_match_reference():
    rng = np.random.default_rng(3)
    start, end = f32(rng.uniform(0, 1, (5, 4))), f32(rng.uniform(0, 1, (5, 4)))
    colliders = np.array([0, 3, 4], np.int32)
    params = f32(rng.uniform(0, 0.1, (3, 2)))
    out = np.empty((3, 9), np.float32)
    pack_spheres(start, end, colliders, params, out)
    assert_close(out, ref.pack_spheres(start, end, colliders, params), 1e-6, "pack_spheres")
    index = np.array([[0, 1], [2, 4]], np.int32)
    cparams = f32(rng.uniform(0, 0.1, (2, 2)))
    out = np.empty((2, 24), np.float32)
    pack_capsules(start, end, index, cparams, out)
    assert_close(out, ref.pack_capsules(start, end, index, cparams), 1e-6, "pack_capsules")
    points0, points1 = f32(rng.uniform(-1, 1, (6, 3))), f32(rng.uniform(-1, 1, (6, 3)))
    triangles = np.array([[0, 1, 2], [3, 4, 5], [0, 0, 1]], np.int32)  # the last is degenerate
    tparams = f32(rng.uniform(0, 0.1, (3, 2)))
    out = np.empty((3, 32), np.float32)
    pack_triangles(points0, points1, triangles, tparams, out)
    assert_close(out, ref.pack_triangles(points0, points1, triangles, tparams), 2e-6, "pack_triangles")
    assert not out[2, 18:24].any()


def test_convex_translation_and_shift_match_reference():
    rng = np.random.default_rng(4)
    box = np.zeros((6, 4), np.float32)
    box[:, :3] = np.vstack([np.eye(3), -np.eye(3)])
    box[:, 3] = 0.5
    moved = box.copy()
    velocity = np.array([0.1, -0.2, 0.05])
    moved[:, 3] += box[:, :3] @ velocity
    plane = random_planes(rng, 1)
    plane_moved = plane.copy()
    plane_moved[0, 3] += 0.3
    planes0, planes1 = np.vstack([box, plane]), np.vstack([moved, plane_moved])
    offsets = np.array([0, 6, 7], np.int32)
    out = np.empty((2, 3), np.float32)
    convex_translation(planes0, planes1, offsets, out)
    # the kernel's ridge regularisation (1e-4) shortens the solution by about 1e-4 of itself
    assert_close(out, ref.convex_translation(planes0, planes1, offsets), 1e-4, "convex_translation")
    np.testing.assert_allclose(out[0], velocity, atol=1e-4)  # a box's translation is seen fully
    np.testing.assert_allclose(out[1], 0.3 * plane[0, :3], atol=1e-4)  # a plane's only along n
    frame = random_frame(rng)
    data = f32(rng.uniform(0, 1, (2, 5)))
    expected = ref.convex_shift(out, frame, 0.25, data)
    convex_shift(out, frame, 0.25, data)
    assert_close(data, expected, 1e-6, "convex_shift")


def test_pack_triangle_of_particle_states_matches_reference():
    """One record from (n,4) particle states (column 3, the inverse mass, is not read)."""
    rng = np.random.default_rng(5)
    prev, cur = rng.normal(0, 1, (6, 4)), rng.normal(0, 1, (6, 4))
    got, want = np.zeros((2, 32)), np.zeros((2, 32))
    pack_triangle(prev, cur, 4, 1, 3, 0.01, 0.3, got, 1)
    ref.pack_triangle(prev, cur, 4, 1, 3, 0.01, 0.3, want, 1)
    np.testing.assert_allclose(got, want, atol=1e-12)
