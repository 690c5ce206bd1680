"""Tethers: anchors are pinned, lengths never undercut the straight line, islands, fallback."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.cook.tethers import build_tethers, pinned_islands
from clothtool.errors import MeshError
from clothtool.mesh import ClothMesh
from clothtool.mesh.shapes import grid


def tether_table(fabric):
    n = fabric.particle_count
    return fabric.tether_anchor.reshape(-1, n), fabric.tether_rest_length.reshape(-1, n)


@given(
    cols=st.integers(2, 9),
    rows=st.integers(2, 9),
    pins=st.lists(st.integers(0, 80), min_size=1, max_size=6),
    mode=st.sampled_from(["geodesic", "euclidean"]),
    k=st.integers(1, 3),
)
def test_tether_properties(cols, rows, pins, mode, k):
    mesh = grid(cols, rows, 0.1)
    n = cols * rows
    pin_file_free = np.zeros(n, bool)
    pin_file_free[[p % n for p in pins]] = True
    edges = np.array(
        [[a, b] for a in range(n) for b in range(n) if a < b and np.linalg.norm(mesh.vertex_pos[a] - mesh.vertex_pos[b]) < 0.1 * 1.5]
    )
    triangles = mesh.face_vertex_indices.reshape(-1, 3)
    built = build_tethers(mesh.vertex_pos, edges, triangles, pin_file_free, mode, k)
    anchor, length, fallbacks = built.anchor, built.length, built.unreachable
    _, islands = pinned_islands(pin_file_free, edges)
    k = min(k, islands)  # slots beyond the number of pinned islands are not made
    anchor, length = anchor.reshape(k, n), length.reshape(k, n)
    assert fallbacks == 0
    owner = np.broadcast_to(np.arange(n), anchor.shape)
    active = anchor != owner
    # anchors are pinned particles; pinned particles have no active tether
    assert pin_file_free[anchor[active]].all()
    assert not active[:, pin_file_free].any()
    # every free particle has at least one tether (the mesh is connected)
    assert active[0, ~pin_file_free].all()
    straight = np.linalg.norm(mesh.vertex_pos[anchor] - mesh.vertex_pos[owner], axis=2)
    assert np.all(length[active] >= straight[active] * (1 - 1e-6))
    if mode == "euclidean":
        np.testing.assert_allclose(length[active], straight[active], rtol=1e-6)
    # slots are ordered nearest island first
    both = active[:-1] & active[1:]
    assert np.all((length[1:] - length[:-1])[both] >= 0)


def test_geodesic_tether_goes_around_a_slit():
    # a 7x7 grid with a vertical slit cut between columns 3 and 4 from row 0 to row 4:
    # the pinned particle at the top left reaches the top right only around the slit's end.
    cols = rows = 7
    mesh = grid(cols, rows, 0.1, quads=True)
    faces = mesh.face_vertex_indices.reshape(-1, 4)
    pos = mesh.vertex_pos.copy()
    index = np.arange(cols * rows).reshape(rows, cols)
    # duplicate column 4's top 5 rows so faces right of the slit use the copies
    copies = {int(index[r, 3]): cols * rows + r for r in range(5)}
    pos = np.vstack([pos, pos[[int(index[r, 3]) for r in range(5)]]])
    new_faces = faces.copy()
    for fi, face in enumerate(faces):
        xs = pos[face, 0]
        if xs.min() >= 0.3 - 1e-9 and (pos[face, 1] >= -0.4 - 1e-9).all():  # right of the slit, above row 4
            new_faces[fi] = [copies.get(int(v), int(v)) for v in face]
    cut = ClothMesh(pos, np.full(len(new_faces), 4), new_faces.reshape(-1))
    top_left = int(index[0, 0])
    pins = np.zeros(pos.shape[0], bool)
    pins[top_left] = True
    # in vertex order (reorder=False): ``pins`` and the corners below are vertex numbers
    fabric = cook_fabric(cut, CookOptions(weld=0.0, tethers="none", reorder=False)).fabric
    # tethers over the cooked triangles, which have no edge across the slit
    built = build_tethers(fabric.rest_pos, fabric.constraint_indices, fabric.triangles, pins, "geodesic")
    anchor, length = built.anchor, built.length
    top_right = int(index[0, 6])
    straight = np.linalg.norm(pos[top_right] - pos[top_left])
    assert anchor[top_right] == top_left
    assert length[top_right] > 1.5 * straight  # down past row 4 and back up


def test_islands_are_numbered_by_lowest_particle():
    pinned = np.array([False, True, True, False, True, False])
    edges = np.array([[0, 1], [1, 2], [2, 3], [3, 4], [4, 5]])
    labels, count = pinned_islands(pinned, edges)
    assert count == 2
    assert labels.tolist() == [-1, 0, 0, -1, 1, -1]


def test_unreachable_piece_falls_back_to_straight_tethers_with_a_warning():
    a = grid(3, 3, 0.1)
    b = grid(3, 3, 0.1, origin=(1.0, 0.0, 0.0))
    pos = np.vstack([a.vertex_pos, b.vertex_pos])
    faces = np.concatenate([a.face_vertex_indices, b.face_vertex_indices + 9])
    mesh = ClothMesh(pos, np.full(faces.size // 3, 3), faces)
    result = cook_fabric(mesh, CookOptions(pin_box=(-0.01, -0.01, -1, 0.01, 0.01, 1), tethers="geodesic", reorder=False))
    assert result.tether_fallbacks == 9
    assert any("no path over the mesh" in w for w in result.warnings)
    anchors, lengths = tether_table(result.fabric)
    assert anchors[0, 9:].tolist() == [0] * 9
    np.testing.assert_allclose(lengths[0, 9:], np.linalg.norm(pos[9:] - pos[0], axis=1), rtol=1e-6)


def test_tethers_without_pins_are_refused():
    with pytest.raises(MeshError, match="needs pinned particles.*--tethers none"):
        cook_fabric(grid(3, 3, 0.1), CookOptions(tethers="geodesic"))


def test_auto_tethers_follow_the_pins():
    assert cook_fabric(grid(3, 3, 0.1), CookOptions()).fabric.tethers_per_particle == 0
    pinned = cook_fabric(grid(3, 3, 0.1), CookOptions(pin_box=(-1, -0.01, -1, 1, 1, 1))).fabric
    assert pinned.tethers_per_particle == 1


def test_two_anchors_per_particle_reach_both_pinned_corners(tmp_path):
    one_island = cook_fabric(
        grid(5, 5, 0.1), CookOptions(pin_box=(-1, -0.01, -1, 1, 1, 1), tether_anchors=2, tethers="euclidean")
    ).fabric
    # the top row is one island: a second slot would stay inactive and only dilute the
    # stiffness, so there is one slot
    assert one_island.tethers_per_particle == 1

    pin_file = tmp_path / "corners.txt"
    pin_file.write_text("0, 4  # the two top corners\n")
    corners = cook_fabric(grid(5, 5, 0.1), CookOptions(pin_file=str(pin_file), tether_anchors=2)).fabric
    anchors, lengths = tether_table(corners)
    free = np.flatnonzero(corners.particle_inv_mass > 0)
    assert set(corners.vertex_numbers(anchors[:, free]).reshape(-1).tolist()) == {0, 4}  # file vertices
    assert np.all(anchors[0, free] != anchors[1, free])
    assert np.all(lengths[0, free] <= lengths[1, free])
