"""Geodesic distances and tethers against closed forms: flat sheets (pinned along an edge, at a
corner, with obtuse triangles), an L whose geodesics bend around the inner corner, a cylinder
(distances in its development), and the edge-graph fallback."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import Delaunay

from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.cook.geodesic import bend_vertices, geodesic_distances
from clothtool.cook.tethers import build_tethers
from clothtool.mesh import topology
from clothtool.mesh.shapes import grid

TOLERANCE = 0.005  # the bar: within 0.5% of the exact geodesic


def triangulated_grid(n: int):
    mesh = grid(n, n, 1.0 / (n - 1))
    triangles, _ = topology.triangulate(mesh.face_vertex_counts, mesh.face_vertex_indices)
    return mesh.vertex_pos.astype(np.float64), triangles.astype(np.int64)


def l_shape(n: int):
    """The unit square (x right, y down to -1) less its bottom right quarter; n odd."""
    pos, triangles = triangulated_grid(n)
    centre = pos[triangles].mean(axis=1)
    return pos, triangles[~((centre[:, 0] > 0.5) & (centre[:, 1] < -0.5))]


def l_shape_geodesic(pos: np.ndarray, source: np.ndarray) -> np.ndarray:
    """Exact distances in the L from a source in its top band (y >= -0.5): straight where the
    segment stays in the L, else straight to the inner corner (0.5, -0.5) and on from there."""
    corner = np.array([0.5, -0.5, 0.0])
    straight = np.linalg.norm(pos - source, axis=1)
    below = pos[:, 1] < -0.5
    t = (source[1] + 0.5) / np.where(below, source[1] - pos[:, 1], 1.0)
    x_at_band_edge = source[0] + t * (pos[:, 0] - source[0])
    blocked = below & (x_at_band_edge > 0.5)
    around = np.linalg.norm(corner - source) + np.linalg.norm(pos - corner, axis=1)
    return np.where(blocked, around, straight)


def cylinder(columns: int, rows: int, radius: float = 0.3, height: float = 1.0):
    """An open cylinder (a prism of ``columns`` flat sides) around +Y."""
    angle = 2 * np.pi * np.arange(columns) / columns
    y = np.linspace(0.0, height, rows)
    pos = np.stack(
        [np.tile(radius * np.cos(angle), rows), np.repeat(y, columns), np.tile(radius * np.sin(angle), rows)], axis=1
    )
    index = np.arange(rows * columns).reshape(rows, columns)
    a, b = index[:-1], np.roll(index[:-1], -1, axis=1)
    c, d = np.roll(index[1:], -1, axis=1), index[1:]
    triangles = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return pos, triangles.astype(np.int64)


def cylinder_geodesic(columns: int, rows: int, source: int, radius: float = 0.3, height: float = 1.0):
    """Distances in the development: a strip whose columns are one side's width apart."""
    width = 2 * radius * np.sin(np.pi / columns)
    column = np.arange(rows * columns) % columns
    row = np.arange(rows * columns) // columns
    around = np.abs(column - source % columns)
    around = np.minimum(around, columns - around)
    return np.hypot(around * width, (row - source // columns) * height / (rows - 1))


def jittered_sheet(n: int, seed: int):
    """A flat square of jittered points, Delaunay-triangulated: irregular and obtuse triangles."""
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(n), np.arange(n))
    xy = np.stack([i.ravel(), j.ravel()], axis=1).astype(np.float64) / (n - 1)
    inner = (xy > 0).all(axis=1) & (xy < 1).all(axis=1)
    xy[inner] += rng.uniform(-0.4, 0.4, (int(inner.sum()), 2)) / (n - 1)
    return np.column_stack([xy, np.zeros(n * n)]), Delaunay(xy).simplices.astype(np.int64)


def relative_error(found: np.ndarray, exact: np.ndarray) -> np.ndarray:
    far = exact > 1e-9
    return np.abs(found[far] - exact[far]) / exact[far]


def graph_distances(pos, triangles, sources):
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    edges = triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    lengths = np.linalg.norm(pos[edges[:, 1]] - pos[edges[:, 0]], axis=1)
    graph = coo_matrix((lengths, (edges[:, 0], edges[:, 1])), shape=(len(pos), len(pos))).tocsr()
    return dijkstra(graph, directed=False, indices=sources, min_only=True)


def test_sheet_pinned_along_its_top_edge_tethers_straight_up():
    n = 33
    mesh = grid(n, n, 1.0 / (n - 1))
    # in vertex order (reorder=False): the expected lengths and anchors are indexed by vertex
    fabric = cook_fabric(mesh, CookOptions(pin_box=(-1, -0.01, -1, 2, 1, 1), tethers="geodesic", reorder=False)).fabric
    anchor, length = fabric.tether_anchor, fabric.tether_rest_length
    depth = -mesh.vertex_pos[:, 1].astype(np.float64)
    assert relative_error(length, depth).max() < TOLERANCE
    np.testing.assert_array_equal(anchor, np.arange(n * n) % n)  # the pinned particle above


def test_sheet_pinned_at_a_corner_tethers_along_straight_lines(tmp_path):
    n = 33
    mesh = grid(n, n, 1.0 / (n - 1))
    pins = tmp_path / "corner.txt"
    pins.write_text("0\n")
    fabric = cook_fabric(mesh, CookOptions(pin_file=str(pins), tethers="geodesic", reorder=False)).fabric
    pos = mesh.vertex_pos.astype(np.float64)
    exact = np.linalg.norm(pos - pos[0], axis=1)
    assert relative_error(fabric.tether_rest_length, exact).max() < TOLERANCE
    assert (fabric.tether_anchor == 0).all()
    # the edge graph's shortest path, which the tethers used before, misses the bar
    pos64, triangles = triangulated_grid(n)
    assert relative_error(graph_distances(pos64, triangles, [0]), exact).max() > 0.05


@pytest.mark.parametrize("seed", [1, 2])
def test_irregular_flat_sheet_with_obtuse_triangles(seed):
    pos, triangles = jittered_sheet(24, seed)
    for source in (0, 24 * 12 + 7):
        dist, root, done = geodesic_distances(pos, triangles, np.array([source]))
        assert done and (root == source).all()
        assert relative_error(dist, np.linalg.norm(pos - pos[source], axis=1)).max() < TOLERANCE


@pytest.mark.parametrize("source_xy", [(1.0, -0.5), (1.0, 0.0), (0.75, -0.25)])
def test_l_shaped_sheet_geodesics_bend_around_the_inner_corner(source_xy):
    n = 41
    pos, triangles = l_shape(n)
    source = int(np.argmin(np.linalg.norm(pos[:, :2] - source_xy, axis=1)))
    dist, root, done = geodesic_distances(pos, triangles, np.array([source]))
    exact = l_shape_geodesic(pos, pos[source])
    used = np.unique(triangles)
    assert done
    assert relative_error(dist[used], exact[used]).max() < TOLERANCE
    assert (exact[used] > np.linalg.norm(pos[used] - pos[source], axis=1) + 0.05).any()  # some bend
    assert np.flatnonzero(bend_vertices(pos, triangles)).tolist() == [n * (n // 2) + n // 2]  # the inner corner


@pytest.mark.parametrize("source_row", [0, 10])
def test_cylinder_distances_are_those_of_its_development(source_row):
    columns, rows = 40, 21
    pos, triangles = cylinder(columns, rows)
    source = source_row * columns + 7
    dist, _, done = geodesic_distances(pos, triangles, np.array([source]))
    assert done
    assert relative_error(dist, cylinder_geodesic(columns, rows, source)).max() < TOLERANCE
    assert not bend_vertices(pos, triangles).any()


def test_cylinder_pinned_along_its_top_ring_tethers_straight_down():
    columns, rows = 40, 21
    pos, triangles = cylinder(columns, rows)
    ring = np.arange(columns)
    pinned = np.zeros(len(pos), bool)
    pinned[ring] = True
    edges = triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    built = build_tethers(pos, edges, triangles, pinned, "geodesic")
    assert relative_error(built.length.astype(np.float64), pos[:, 1]).max() < TOLERANCE
    np.testing.assert_array_equal(built.anchor, np.arange(len(pos)) % columns)


def test_curved_garment_tethers_lie_between_the_straight_line_and_the_edge_graph():
    from clothtool.io.meshin import read_mesh
    from tests.conftest import REPO

    fabric = cook_fabric(read_mesh(REPO / "examples/skirt/skirt.usda"), CookOptions(pin_attr="pin", tethers="none")).fabric
    pos, triangles = fabric.rest_pos.astype(np.float64), fabric.triangles.astype(np.int64)
    for sources in (np.array([0]), np.flatnonzero(fabric.particle_inv_mass == 0)):
        dist, root, done = geodesic_distances(pos, triangles, sources)
        assert done and np.isin(root, sources).all()
        assert (dist <= graph_distances(pos, triangles, sources) * (1 + 1e-9)).all()
        assert (dist >= np.linalg.norm(pos - pos[root], axis=1) * (1 - 1e-6)).all()


def test_out_of_budget_island_falls_back_to_edge_graph_distances_with_a_note():
    pos, triangles = triangulated_grid(9)
    edges = triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    pinned = np.zeros(len(pos), bool)
    pinned[0] = True
    assert not geodesic_distances(pos, triangles, np.array([0]), max_updates=5)[2]
    built = build_tethers(pos, edges, triangles, pinned, "geodesic", max_updates=5)
    assert built.graph_islands == 1
    assert len(built.notes) == 1 and "edge-graph distances" in built.notes[0] and "particle 0" in built.notes[0]
    np.testing.assert_allclose(built.length, graph_distances(pos, triangles, [0]), rtol=1e-6)
    assert build_tethers(pos, edges, triangles, pinned, "geodesic").notes == ()
