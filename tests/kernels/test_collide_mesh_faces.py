"""collide_mesh_faces (collider points against cloth faces, through the collider's grid)
against tests/reference/collide_mesh_faces.py (every point against every face, no grid), and
collider_owners (every vertex and edge owned once, samples by length)."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.solver.kernels.collide_mesh import grid_cell_ranges, grid_fill, grid_layout, triangle_bounds
from clothtool.solver.kernels.collide_mesh_faces import collide_mesh_faces
from clothtool.solver.kernels.collide_pose import pack_triangles
from clothtool.solver.meshfaces import MAX_EDGE_SAMPLES, collider_owners
from tests.kernels._data import assert_close
from tests.reference import collide_mesh_faces as ref

MARGIN = 0.007


def sheet(n: int, size: float, rng, bump: float) -> tuple[np.ndarray, np.ndarray]:
    """A jittered n x n grid of points in the plane y = 0 (heights ~ bump) and its triangles."""
    g = np.linspace(-size / 2, size / 2, n)
    x, z = np.meshgrid(g, g, indexing="ij")
    points = np.stack([x, rng.normal(0, bump, x.shape), z], -1).reshape(-1, 3)
    points[:, [0, 2]] += rng.normal(0, 0.1 * size / n, (points.shape[0], 2))
    index = np.arange(n * n).reshape(n, n)
    q0, q1, q2, q3 = index[:-1, :-1].ravel(), index[1:, :-1].ravel(), index[1:, 1:].ravel(), index[:-1, 1:].ravel()
    return points, np.concatenate([np.stack([q0, q1, q2], 1), np.stack([q0, q2, q3], 1)]).astype(np.int32)


def grid_for(triangle_data, points0, points1, triangles):
    margins = np.ascontiguousarray(triangle_data[:, 24])
    t = triangles.shape[0]
    bounds = np.zeros((t, 6))
    triangle_bounds(points0, points1, triangles, margins, 1e-9, bounds)
    grid = np.zeros(7)
    cells = grid_layout(bounds, 16.0 * t, grid)
    cell_ranges = np.zeros((t, 6), np.int32)
    entries = grid_cell_ranges(bounds, grid, cell_ranges)
    cell_start = np.zeros(cells + 1, np.int32)
    cell_items = np.zeros(entries, np.int32)
    grid_fill(cell_ranges, grid, cell_start, cell_items)
    return cell_start, cell_items, cell_ranges, grid


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("mass_scale", [0.0, 10.0])
def test_collide_mesh_faces_matches_reference(seed, mass_scale):
    """A bumpy cloth sheet tangled with a bumpy collider sheet, both moving: near contacts and
    crossings from both sides, pinned corners, samples inside the collider's edges."""
    rng = np.random.default_rng(seed)
    cloth, cloth_triangles = sheet(6, 0.3, rng, 0.006)
    prev = np.zeros((cloth.shape[0], 4))
    prev[:, :3] = cloth
    prev[:, 3] = np.where(rng.random(cloth.shape[0]) < 0.15, 0.0, rng.uniform(0.5, 2.0, cloth.shape[0]))
    cur = prev.copy()
    cur[:, :3] += rng.normal(0, 0.003, (cloth.shape[0], 3))
    body, triangles = sheet(4, 0.34, rng, 0.006)
    body_end = body + rng.normal(0, 0.002, body.shape)
    params = np.column_stack([rng.uniform(0.5, 1.0, triangles.shape[0]) * MARGIN, rng.uniform(0, 0.6, triangles.shape[0])])
    data = np.zeros((triangles.shape[0], 32))
    pack_triangles(body, body_end, triangles, params, data)
    owners = collider_owners(triangles, body, 0.03)
    assert owners[:, 1:].sum() > 0
    expected, count = ref.collide_mesh_faces(cloth_triangles, owners, data, prev, mass_scale, 1.0, cur)
    got = cur.copy()
    corrected = collide_mesh_faces(
        cloth_triangles, owners, data, *grid_for(data, body, body_end, triangles), _identity(),
        prev, MARGIN, mass_scale, 1.0, np.zeros((1, 32)), got,
    )
    assert corrected == count > 5
    assert_close(got, expected, 1e-9, "particles")
    assert np.abs(got - cur).max() > 1e-3  # the faces did move


def _identity() -> np.ndarray:
    """The frame (8,3) of a cloth simulated in world space: R = I, T = 0 at both ends."""
    frame = np.zeros((8, 3))
    frame[0:3] = frame[4:7] = np.eye(3)
    return frame


def test_collider_owners_own_every_vertex_and_edge_once():
    rng = np.random.default_rng(7)
    points, triangles = sheet(5, 1.0, rng, 0.0)
    owners = collider_owners(triangles, points, 0.1)
    corners = [triangles[t, k] for t in range(len(triangles)) for k in range(3) if owners[t, 0] >> k & 1]
    assert sorted(corners) == list(range(points.shape[0]))
    edges = {}
    for t, tri in enumerate(triangles):
        for e in range(3):
            key = tuple(sorted((tri[e], tri[(e + 1) % 3])))
            edges.setdefault(key, []).append(owners[t, 1 + e])
    for (i, j), counts in edges.items():
        length = np.linalg.norm(points[i] - points[j])
        want = min(int(np.ceil(length / 0.1)) - 1, MAX_EDGE_SAMPLES)
        assert sorted(counts, reverse=True)[0] == want and sum(counts) == want, (i, j, counts, length)
    assert collider_owners(triangles, points, float("inf"))[:, 1:].sum() == 0
