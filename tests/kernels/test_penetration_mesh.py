"""penetration_mesh kernels (triangle distances, winding numbers, per-face depths through the
grid) against tests/reference/penetration_mesh.py on random inputs."""

from __future__ import annotations

import numpy as np

from clothtool.solver.kernels.penetration_mesh import (
    face_depths,
    inside_depths,
    point_triangle_distance,
    segment_crosses_triangle,
    segment_distance,
    triangle_distance,
    winding_number,
)
from clothtool.solver.penetration import closed_meshes
from tests.kernels.test_collide_mesh_faces import grid_for, sheet
from tests.physics.test_collision import box_mesh
from tests.reference import penetration_mesh as ref


def test_distances_match_reference():
    rng = np.random.default_rng(3)
    crossings = 0
    for _ in range(60):
        A, B = rng.normal(0, 0.1, (3, 3)), rng.normal(0.05, 0.1, (3, 3))
        p = rng.normal(0, 0.1, 3)
        assert abs(point_triangle_distance(p, *A) - ref.point_triangle_distance(p, *A)) < 1e-9
        assert abs(segment_distance(A[0], A[1], B[0], B[1]) - ref.segment_distance(A[0], A[1], B[0], B[1])) < 1e-6
        cross = segment_crosses_triangle(A[0], A[1], *B)
        assert cross == ref.segment_crosses_triangle(A[0], A[1], *B)
        crossings += cross
        assert abs(triangle_distance(A, B) - ref.triangle_distance(A, B)) < 1e-6
    assert crossings > 3


def test_winding_and_depths_match_reference():
    """A box (closed) and a bumpy sheet (open); cloth faces near, through and inside both."""
    rng = np.random.default_rng(4)
    box = box_mesh((-0.1, -0.2, -0.1), (0.1, 0.0, 0.1), 2)
    plate, plate_triangles = sheet(4, 0.3, rng, 0.01)
    plate[:, 1] += 0.1
    points = np.concatenate([box.mesh_points.astype(np.float64), plate])
    triangles = np.concatenate([box.mesh_triangles, plate_triangles + box.mesh_points.shape[0]]).astype(np.int32)
    owner = np.repeat([0, 1], [box.mesh_triangles.shape[0], plate_triangles.shape[0]]).astype(np.int32)
    first = np.array([0, box.mesh_triangles.shape[0], triangles.shape[0]], np.int64)
    closed = closed_meshes(points, triangles, owner, 2)
    assert closed.tolist() == [True, False]
    margin = np.array([0.004, 0.006])
    cloth = rng.uniform((-0.15, -0.05, -0.15), (0.15, 0.15, 0.15), (40, 3))
    for p in cloth[:10]:
        assert abs(winding_number(p, points, triangles, 0, first[1]) - ref.winding_number(p, points, triangles, 0, first[1])) < 1e-9
    got, want = np.empty(40), np.empty(40)
    inside_depths(cloth, points, triangles, first, closed, margin, got)
    ref.inside_depths(cloth, points, triangles, first, closed, margin, want)
    np.testing.assert_allclose(got, want, atol=1e-9)
    assert np.isfinite(got).sum() > 3
    faces = rng.integers(0, 40, (60, 3)).astype(np.int32)
    margins = margin[owner]
    got, want = np.empty(60), np.empty(60)
    corners = inside_corner(cloth, points, triangles, first, closed, margin)
    grid = grid_for(_records(margins, triangles.shape[0]), points, points, triangles)
    face_depths(cloth, faces, corners, points, triangles, margins, *grid, got)
    ref.face_depths(cloth, faces, corners, points, triangles, margins, None, None, None, None, want)
    near = want > -np.inf
    assert near.sum() > 10
    np.testing.assert_allclose(got[near], want[near], atol=1e-6)
    assert (got[~near] <= 0).all()  # pairs beyond the margin may show as clearance or -inf


def inside_corner(cloth, points, triangles, first, closed, margin):
    out = np.empty(cloth.shape[0])
    inside_depths(cloth, points, triangles, first, closed, margin, out)
    return out


def _records(margins, t):
    data = np.zeros((t, 32))
    data[:, 24] = margins
    return data
