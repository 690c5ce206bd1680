"""collide_mesh kernels (point-triangle contacts, the world-space grid) against
tests/reference/collide_mesh.py; the grid query against a brute-force loop over triangles."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from clothtool.solver.kernels.collide_mesh import (
    box_cell,
    box_cell_count,
    box_cells,
    closest_on_triangle,
    first_shared_cell,
    grid_cell,
    grid_cell_ranges,
    grid_fill,
    grid_layout,
    mesh_contact,
    plane_coordinates,
    to_world,
    triangle_bounds,
    triangle_contact,
    triangle_contact_within,
)
from tests.kernels._data import F32, assert_close, f32
from tests.reference import collide_mesh as ref
from tests.reference.collide_pose import pack_triangles, pose_points


def test_closest_on_triangle_matches_reference():
    """Points in every Voronoi region (corners, edges, face, both sides)."""
    rng = np.random.default_rng(0)
    for _ in range(300):
        a, b, c = (f32(rng.uniform(-1, 1, 3)) for _ in range(3))
        p = f32((a + b + c) / 3 + rng.normal(0, 1.0, 3))
        u, v = closest_on_triangle(*p, *a, *b, *c)
        ru, rv = ref.closest_on_triangle(*p, *a, *b, *c)
        point = a + u * (b - a) + v * (c - a)
        expected = a + ru * (b - a) + rv * (c - a)
        assert np.linalg.norm(point - expected) < 2e-5 * (1 + np.linalg.norm(p - expected)), (u, v, ru, rv)


def test_plane_coordinates_matches_reference():
    rng = np.random.default_rng(1)
    for _ in range(50):
        a, b, c, p = (f32(rng.uniform(-1, 1, 3)) for _ in range(4))
        u, v, ok = plane_coordinates(*p, *a, *b, *c)
        ru, rv, rok = ref.plane_coordinates(*p, *a, *b, *c)
        assert ok and rok
        assert abs(u - ru) < 1e-3 * (1 + abs(ru)) and abs(v - rv) < 1e-3 * (1 + abs(rv))
    a = f32([0, 0, 0])
    assert not plane_coordinates(*a, *a, *f32([1, 0, 0]), *f32([2, 0, 0]))[2]


def triangle_record(rng, margin=0.02, motion=0.01):
    start = rng.uniform(-0.5, 0.5, (3, 3))
    end = start + rng.normal(0, motion, 3) + rng.normal(0, motion / 4, (3, 3))
    tris = np.array([[0, 1, 2]], np.int32)
    return f32(pack_triangles(f32(start), f32(end), tris, f32([[margin, 0.4]])))


@pytest.mark.parametrize("seed", range(3))
def test_triangle_contact_matches_reference(seed):
    """Particles near a moving triangle: staying on their side within and beyond the margin,
    crossing through it, passing beside it."""
    rng = np.random.default_rng(seed)
    kinds = {"near": 0, "cross": 0}
    for _ in range(150):
        data = triangle_record(rng)
        start, end = data[0, :9].reshape(3, 3), data[0, 9:18].reshape(3, 3)
        n0 = data[0, 18:21]
        w = rng.dirichlet([1, 1, 1]) * rng.uniform(0.8, 1.3)  # mostly inside, some beside
        q = f32(w @ start + n0 * rng.uniform(-0.03, 0.03))
        p = f32(w @ end + n0 * rng.uniform(-0.04, 0.04) + rng.normal(0, 0.005, 3))
        got = triangle_contact(*p, *q, data, 0)
        want = ref.triangle_contact(*p, *q, data, 0)
        # skip cases within float32 rounding of a decision
        height = np.sign(n0 @ (q - start[0])) * (data[0, 21:24] @ (p - end[0]))
        if abs(height) < 1e-5 or abs(np.linalg.norm(want[1:4]) if want[0] else 0.0) < 1e-5:
            continue
        assert got[0] == want[0], (got, want)
        if want[0]:
            kinds["cross" if height < 0 else "near"] += 1
            np.testing.assert_allclose(got[1:4], want[1:4], atol=2e-5)
            np.testing.assert_allclose(got[4:6], want[4:6], atol=2e-3)
    assert kinds["near"] > 10 and kinds["cross"] > 10, kinds


def test_thin_sheet_is_solid_from_both_sides():
    """A particle that comes from below a one-triangle sheet and goes through it ends below,
    one from above ends above; one passing beside it is not touched."""
    data = f32(pack_triangles(f32([[0, 0, 0], [1, 0, 0], [0, 0, 1]]), f32([[0, 0, 0], [1, 0, 0], [0, 0, 1]]),
                              np.array([[0, 2, 1]], np.int32), f32([[0.01, 0.5]])))
    assert data[0, 19] > 0.99  # the normal is +y
    hit, dx, dy, dz, *_ = triangle_contact(F32(0.2), F32(0.05), F32(0.2), F32(0.2), F32(-0.2), F32(0.2), data, 0)
    assert hit and abs(dy - (-0.01 - 0.05)) < 1e-6
    hit, dx, dy, dz, *_ = triangle_contact(F32(0.2), F32(-0.05), F32(0.2), F32(0.2), F32(0.2), F32(0.2), data, 0)
    assert hit and abs(dy - (0.01 + 0.05)) < 1e-6
    hit, *_ = triangle_contact(F32(1.2), F32(-0.05), F32(1.2), F32(1.2), F32(0.2), F32(1.2), data, 0)
    assert not hit


def random_mesh(rng, n=8):
    """A bumpy height field of (n-1)^2 * 2 triangles over [-0.5, 0.5]^2, normals up."""
    x, z = np.meshgrid(np.linspace(-0.5, 0.5, n), np.linspace(-0.5, 0.5, n))
    y = 0.05 * rng.normal(size=x.shape)
    points = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    index = np.arange(n * n).reshape(n, n)
    a, b, c, d = index[:-1, :-1].ravel(), index[:-1, 1:].ravel(), index[1:, 1:].ravel(), index[1:, :-1].ravel()
    triangles = np.concatenate([np.stack([a, d, c], 1), np.stack([a, c, b], 1)]).astype(np.int32)
    return f32(points), triangles


def build_grid(points0, points1, triangles, margins, max_cells):
    bounds = np.empty((triangles.shape[0], 6), np.float32)
    triangle_bounds(points0, points1, triangles, margins, F32(1e-6), bounds)
    grid = np.empty(7, np.float32)
    cells = grid_layout(bounds, float(max_cells), grid)
    ranges = np.empty((triangles.shape[0], 6), np.int32)
    entries = grid_cell_ranges(bounds, grid, ranges)
    cell_start = np.empty(cells + 1, np.int32)
    cell_items = np.empty(entries, np.int32)
    grid_fill(ranges, grid, cell_start, cell_items)
    return bounds, grid, cells, ranges, entries, cell_start, cell_items


def test_grid_build_matches_reference():
    rng = np.random.default_rng(2)
    points, triangles = random_mesh(rng)
    moved = f32(points + [0.05, 0.0, -0.02])
    margins = f32(rng.uniform(0.005, 0.02, triangles.shape[0]))
    bounds, grid, cells, ranges, entries, cell_start, cell_items = build_grid(points, moved, triangles, margins, 200)
    assert_close(bounds, ref.triangle_bounds(points, moved, triangles, margins, 1e-6), 1e-6, "bounds")
    ref_cells, ref_grid = ref.grid_layout(bounds, 200)
    assert cells == ref_cells <= 200
    assert_close(grid, ref_grid, 1e-5 * np.abs(ref_grid).max(), "grid")
    ref_entries, ref_ranges = ref.grid_cell_ranges(bounds, grid)
    assert entries == ref_entries
    np.testing.assert_array_equal(ranges, ref_ranges)
    ref_start, ref_items = ref.grid_fill(ranges, grid)
    np.testing.assert_array_equal(cell_start, ref_start)
    np.testing.assert_array_equal(cell_items, ref_items)
    for x in (-5.0, float(grid[0]) + 0.5 / grid[3], 5.0):
        assert grid_cell(F32(x), grid, 0) == ref.grid_cell(x, grid, 0)
    # boxes inside, across the border and wholly outside the grid
    centre = grid[:3] + 0.5 * grid[4:7] / grid[3]
    for _ in range(200):
        lo = centre + rng.normal(0.0, 1.0, 3) * grid[4:7] / grid[3]
        hi = lo + rng.uniform(0.0, 0.5, 3) * grid[4:7] / grid[3]
        assert box_cells(*lo, *hi, grid) == ref.box_cells(lo, hi, grid)


def test_box_walk_meets_each_triangle_once():
    """box_cell and first_shared_cell against the reference, and the walk they make: every
    triangle with a cell in the box is met exactly once, in the box's first cell it shares."""
    rng = np.random.default_rng(5)
    points, triangles = random_mesh(rng)
    margins = f32(np.full(triangles.shape[0], 0.01))
    _, grid, _, ranges, _, cell_start, cell_items = build_grid(points, points, triangles, margins, 300)
    centre = grid[:3] + 0.5 * grid[4:7] / grid[3]
    for _ in range(100):
        lo = centre + rng.normal(0.0, 0.6, 3) * grid[4:7] / grid[3]
        hi = lo + rng.uniform(0.0, 0.6, 3) * grid[4:7] / grid[3]
        outside, x0, y0, z0, x1, y1, z1 = box_cells(*lo, *hi, grid)
        if outside:
            continue
        count = box_cell_count(x0, y0, z0, x1, y1, z1)
        assert count == ref.box_cell_count(x0, y0, z0, x1, y1, z1)
        met = []
        for k in range(count):
            x, y, z, cell = box_cell(k, x0, y0, z0, x1, y1, z1, grid)
            assert (x, y, z, cell) == ref.box_cell(k, x0, y0, z0, x1, y1, z1, grid)
            for t in cell_items[cell_start[cell]:cell_start[cell + 1]]:
                first = first_shared_cell(t, x, y, z, x0, y0, z0, ranges)
                assert first == ref.first_shared_cell(t, x, y, z, x0, y0, z0, ranges)
                if first:
                    met.append(int(t))
        overlapping = [
            t for t in range(triangles.shape[0])
            if (ranges[t, :3] <= [x1, y1, z1]).all() and (ranges[t, 3:] >= [x0, y0, z0]).all()
        ]
        assert sorted(met) == overlapping  # each once, none missed


def test_to_world_matches_reference():
    frame = np.zeros((8, 3))
    frame[0:3] = Rotation.from_rotvec([0.1, 0.2, 0.3]).as_matrix()
    frame[3] = [1, 2, 3]
    frame[4:7] = Rotation.from_rotvec([-0.3, 0.0, 0.5]).as_matrix()
    frame[7] = [-1, 0, 2]
    for end in (0, 1):
        np.testing.assert_allclose(to_world(frame, end, 0.5, -0.25, 2.0), ref.to_world(frame, end, 0.5, -0.25, 2.0), atol=1e-12)


@pytest.mark.parametrize("seed", range(2))
def test_mesh_contact_grid_query_matches_brute_force(seed):
    """Particles around a moving bumpy mesh, seen from a moving frame: the grid finds the
    same deepest contact as a loop over every triangle."""
    rng = np.random.default_rng(seed)
    world0, triangles = random_mesh(rng, 6)
    world1 = f32(world0 + rng.normal(0, 0.01, 3))
    margin = 0.02
    params = f32(np.tile([margin, 0.3], (triangles.shape[0], 1)))
    _, grid, _, ranges, _, cell_start, cell_items = build_grid(world0, world1, triangles, f32(params[:, 0]), 4 * len(triangles))
    frame = np.zeros((8, 3))
    frame[0:3] = Rotation.from_rotvec([0.02, 0.1, -0.03]).as_matrix()
    frame[3] = [0.1, -0.05, 0.02]
    frame[4:7] = Rotation.from_rotvec([0.025, 0.11, -0.03]).as_matrix()
    frame[7] = [0.11, -0.05, 0.025]
    local0 = f32(pose_points(world0, world1, frame, 0.0, 0))
    local1 = f32(pose_points(world0, world1, frame, 1.0, 1))
    data = f32(pack_triangles(local0, local1, triangles, params))
    hits = 0
    for _ in range(120):
        q = f32(rng.uniform([-0.6, -0.1, -0.6], [0.6, 0.12, 0.6]))
        p = f32(q + rng.normal(0, 0.03, 3))
        got = mesh_contact(*p, *q, data, cell_start, cell_items, ranges, grid, frame)
        want = ref.mesh_contact(*p, *q, data, cell_start, cell_items, ranges, grid, frame)
        assert got[0] == want[0], (p, q, got, want)
        if want[0]:
            hits += 1
            np.testing.assert_allclose(got[1:4], want[1:4], atol=3e-5)
            np.testing.assert_allclose(got[4:7], want[4:7], atol=1e-4)
            assert got[7] == pytest.approx(want[7])
    assert hits > 12


def test_triangle_contact_within_uses_its_margin():
    """The record's box grown by 2 cm, the contact decided with a 1 cm margin: as the
    reference with a 1 cm record."""
    rng = np.random.default_rng(11)
    hits = 0
    for _ in range(200):
        data = triangle_record(rng, margin=0.02)
        end, n1 = data[0, 9:18].reshape(3, 3), data[0, 21:24]
        p = f32(rng.dirichlet([1, 1, 1]) @ end + n1 * rng.uniform(-0.005, 0.02))
        q = f32(p - n1 * 0.001)
        got = triangle_contact_within(*p, *q, data, 0, F32(0.01))
        want = ref.triangle_contact_within(*p, *q, data, 0, 0.01)
        assert got[0] == want[0]
        if want[0]:
            hits += 1
            assert_close(got[1:4], want[1:4], 1e-5, "push-out")
    assert hits > 20
