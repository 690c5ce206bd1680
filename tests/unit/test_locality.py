"""The cook's particle order for memory locality (clothtool.cook.locality) and its bookkeeping.

Known answers: a permutation composed with its inverse is the identity; a Z-order curve over
the corners of a cube visits them in the order of their interleaved bits; reverse
Cuthill-McKee brings a randomly numbered N x N grid back to a bandwidth of about N.
"""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.cook import locality
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.errors import FabricError
from clothtool.fabric import PhaseType, conflicting_set
from clothtool.mesh.shapes import grid


def shuffled_grid(n: int, seed: int = 3, quads: bool = True):
    mesh = grid(n, n, 1.0 / (n - 1), quads=quads)
    return locality.reorder_mesh(mesh, np.random.default_rng(seed).permutation(mesh.vertex_count))


def bandwidth(mesh) -> int:
    """Largest index distance between the two ends of a mesh edge."""
    graph = locality.edge_graph(mesh.vertex_count, mesh.face_vertex_counts, mesh.face_vertex_indices).tocoo()
    return int(np.abs(graph.row.astype(np.int64) - graph.col).max())


def test_reorder_mesh_moves_positions_attributes_and_face_indices_together():
    mesh = grid(4, 3, 0.5, quads=True)
    mesh = mesh.replace(vertex_attrs={"w": np.arange(12, dtype=np.float32)})
    order = np.random.default_rng(0).permutation(12)
    moved = locality.reorder_mesh(mesh, order)
    np.testing.assert_array_equal(moved.vertex_pos, mesh.vertex_pos[order])
    np.testing.assert_array_equal(moved.vertex_attrs["w"], order.astype(np.float32))
    # every face corner still sits at the same point, and UVs are untouched
    np.testing.assert_array_equal(moved.vertex_pos[moved.face_vertex_indices], mesh.vertex_pos[mesh.face_vertex_indices])
    np.testing.assert_array_equal(moved.face_vertex_uv, mesh.face_vertex_uv)
    back = locality.reorder_mesh(moved, locality.inverse_permutation(order))
    np.testing.assert_array_equal(back.vertex_pos, mesh.vertex_pos)
    np.testing.assert_array_equal(back.face_vertex_indices, mesh.face_vertex_indices)


def test_renumbered_vertex_map_keeps_removed_vertices_removed():
    order = np.array([2, 0, 1])
    vertex_map = np.array([0, -1, 2, 1, 0])  # file vertex -> vertex, -1 = removed
    # vertex 0 became particle 1, vertex 1 particle 2, vertex 2 particle 0
    np.testing.assert_array_equal(locality.renumber_vertex_map(vertex_map, order), [1, -1, 0, 2, 1])


def test_rcm_restores_a_narrow_band_on_a_shuffled_grid():
    n = 30
    mesh = shuffled_grid(n)
    assert bandwidth(mesh) > 10 * n  # random numbering: edges span the whole index range
    order = locality.rcm_order(mesh)
    assert sorted(order.tolist()) == list(range(n * n))
    assert bandwidth(locality.reorder_mesh(mesh, order)) <= 2 * n  # a quad grid's RCM band is about n
    np.testing.assert_array_equal(order, locality.rcm_order(mesh))  # deterministic


def test_morton_order_of_cube_corners_follows_interleaved_bits():
    corners = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], np.float32)  # code x + 2y + 4z
    rng = np.random.default_rng(1)
    shuffle = rng.permutation(8)
    mesh = grid(2, 2).replace(vertex_pos=corners[shuffle][:4])  # any 4 of them, faces unused
    order = locality.morton_order(mesh)
    codes = corners[shuffle][:4] @ np.array([1, 2, 4])
    np.testing.assert_array_equal(codes[order], np.sort(codes))


def test_cook_renumbers_particles_and_keeps_the_way_back_to_vertices():
    mesh = shuffled_grid(12)
    pin = np.zeros(mesh.vertex_count, np.float32)
    pin[[5, 17]] = 1.0
    mesh = mesh.replace(vertex_attrs={"pin": pin})
    fabric = cook_fabric(mesh, CookOptions(pin_attr="pin", virtual_particles=1)).fabric
    assert fabric.reordered
    assert sorted(fabric.particle_vertex.tolist()) == list(range(mesh.vertex_count))
    np.testing.assert_array_equal(fabric.in_vertex_order(fabric.rest_pos), mesh.vertex_pos)
    np.testing.assert_array_equal(fabric.vertex_face_indices(), mesh.face_vertex_indices)
    assert np.flatnonzero(fabric.in_vertex_order(fabric.pinned)).tolist() == [5, 17]
    assert {fabric.vertex_of(int(p)) for p in np.flatnonzero(fabric.pinned)} == {5, 17}
    # tethers anchor at the pins, constraints join mesh neighbours, sets stay conflict-free
    assert set(fabric.tether_anchor[~fabric.pinned[np.arange(fabric.tether_anchor.size) % 144]].tolist()) <= set(
        np.flatnonzero(fabric.pinned).tolist()
    )
    assert conflicting_set(fabric) is None
    stretch = fabric.constraint_indices[fabric.phase_constraints(0)]
    assert PhaseType(int(fabric.phase_type[0])) in (PhaseType.VERTICAL, PhaseType.HORIZONTAL)
    length = np.linalg.norm(fabric.rest_pos[stretch[:, 0]] - fabric.rest_pos[stretch[:, 1]], axis=1)
    np.testing.assert_allclose(length, 1.0 / 11, rtol=1e-5)


def test_reordered_constraints_touch_nearby_memory():
    """On a shuffled grid the renumbering brings every constraint's particles within a band
    of about the grid's width (the scanline order's), from the whole index range."""
    n = 40
    mesh = shuffled_grid(n, quads=False)
    plain = cook_fabric(mesh, CookOptions(reorder=False, tethers="none")).fabric
    local = cook_fabric(mesh, CookOptions(tethers="none")).fabric
    span = lambda f: np.abs(np.diff(f.constraint_indices.astype(np.int64), axis=1))  # noqa: E731
    assert np.median(span(plain)) > 10 * n
    assert span(local).max() <= 3 * n
    assert plain.constraint_count == local.constraint_count
    assert local.set_count <= plain.set_count


def test_no_reorder_keeps_vertex_order():
    mesh = shuffled_grid(8)
    fabric = cook_fabric(mesh, CookOptions(reorder=False)).fabric
    assert not fabric.reordered and fabric.vertex_particle is None
    np.testing.assert_array_equal(fabric.rest_pos, mesh.vertex_pos)
    assert fabric.in_vertex_order(fabric.rest_pos) is fabric.rest_pos
    assert fabric.vertex_of(7) == 7


def test_cook_is_deterministic():
    mesh = shuffled_grid(10)
    first = cook_fabric(mesh, CookOptions(tethers="none")).fabric
    second = cook_fabric(mesh, CookOptions(tethers="none")).fabric
    np.testing.assert_array_equal(first.particle_vertex, second.particle_vertex)
    np.testing.assert_array_equal(first.constraint_indices, second.constraint_indices)


@pytest.mark.parametrize(
    "particle_vertex, message",
    [
        (np.zeros(5, np.int32), "must be the particle count"),
        (np.zeros(16, np.int32), "names vertex 0 16 times"),
        (np.arange(1, 17, dtype=np.int32), "outside [0, 16)"),
    ],
)
def test_validate_refuses_a_particle_vertex_that_is_no_permutation(particle_vertex, message):
    fabric = cook_fabric(grid(4, 4, 0.1), CookOptions(tethers="none")).fabric
    with pytest.raises(FabricError, match="particle_vertex") as info:
        fabric.replace(particle_vertex=particle_vertex).validate()
    assert message in str(info.value)
