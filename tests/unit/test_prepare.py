"""Mesh checks and repairs: every bad input gives one line naming the element and the fix."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.errors import MeshError
from clothtool.mesh import ClothMesh
from clothtool.mesh.prepare import prepare_mesh
from clothtool.mesh.shapes import grid

SQUARE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)


def two_triangles(**kwargs):
    return ClothMesh.from_triangles(SQUARE, [[0, 1, 2], [0, 2, 3]], source="cloth.obj", **kwargs)


def one_line(message: str) -> bool:
    return "\n" not in message and message.startswith("cloth.obj: ")


def test_clean_mesh_passes_unchanged():
    prepared = prepare_mesh(two_triangles())
    assert prepared.warnings == [] and prepared.welded == 0
    assert prepared.mesh.face_vertex_indices.tolist() == [0, 1, 2, 0, 2, 3]
    assert prepared.vertex_map.tolist() == [0, 1, 2, 3]


@pytest.mark.parametrize(
    "mesh, pattern",
    [
        (ClothMesh.from_triangles(np.zeros((0, 3)), np.zeros((0, 3), int), source="cloth.obj"), "mesh is empty"),
        (ClothMesh.from_triangles(SQUARE, [[0, 1, 7]], source="cloth.obj"), r"face 0 references vertex 7 .* 4 vertices"),
        (ClothMesh.from_triangles(SQUARE, [[0, 1, -2]], source="cloth.obj"), r"face 0 references vertex -2"),
        (ClothMesh.from_faces(SQUARE, [[0, 1, 2], [0, 2]], source="cloth.obj"), r"face 1 has 2 vertices"),
        (
            ClothMesh.from_triangles(np.vstack([SQUARE[:3], [np.nan, 0, 0]]), [[0, 1, 2], [0, 2, 3]], source="cloth.obj"),
            r"vertex 3 has a NaN or infinite coordinate",
        ),
        (
            ClothMesh.from_triangles(np.vstack([SQUARE[:3], [np.inf, 0, 0]]), [[0, 1, 2]], source="cloth.obj"),
            r"vertex 3 has a NaN or infinite",
        ),
        (
            ClothMesh.from_triangles(SQUARE, [[0, 1, 2]], source="cloth.obj", vertex_attrs={"pin": [0, np.nan, 0, 0]}),
            r"attribute 'pin' is NaN or infinite at vertex 1",
        ),
    ],
)
def test_fatal_inputs(mesh, pattern):
    with pytest.raises(MeshError, match=pattern) as info:
        prepare_mesh(mesh)
    assert one_line(str(info.value))


def test_non_manifold_edge_is_refused():
    pos = np.vstack([SQUARE, [[0.5, 0.5, 1.0]]])
    mesh = ClothMesh.from_triangles(pos, [[0, 1, 2], [0, 2, 3], [0, 2, 4]], source="cloth.obj")
    with pytest.raises(MeshError, match=r"edge \(0, 2\) is shared by 3 faces .*non-manifold") as info:
        prepare_mesh(mesh)
    assert one_line(str(info.value))


def test_moebius_strip_is_refused():
    # a strip of 6 quads whose ends join with a half twist
    k = 6
    angles = np.linspace(0, 2 * np.pi, k, endpoint=False)
    pos = []
    for a in angles:
        twist = a / 2
        for s in (-0.2, 0.2):
            r = 1 + s * np.cos(twist)
            pos.append((r * np.cos(a), r * np.sin(a), s * np.sin(twist)))
    faces = [[2 * i, 2 * i + 1, 2 * i + 3, 2 * i + 2] for i in range(k - 1)]
    faces.append([2 * (k - 1), 2 * (k - 1) + 1, 0, 1])  # joined reversed: the half twist
    with pytest.raises(MeshError, match="cannot be oriented consistently"):
        prepare_mesh(ClothMesh.from_faces(np.array(pos), faces, source="cloth.obj"))


def test_flipped_face_is_repaired_and_reported():
    mesh = ClothMesh.from_triangles(SQUARE, [[0, 1, 2], [0, 3, 2]], source="cloth.obj")  # second flipped
    prepared = prepare_mesh(mesh)
    assert prepared.mesh.face_vertex_indices.tolist() == [0, 1, 2, 0, 2, 3]
    assert len(prepared.warnings) == 1 and "faces 1 were wound opposite" in prepared.warnings[0]
    with pytest.raises(MeshError, match="wound opposite.*--strict"):
        prepare_mesh(mesh, strict=True)


def test_flipping_keeps_the_majority_orientation_and_uvs():
    mesh = grid(4, 4, 0.1)
    faces = mesh.face_vertex_indices.reshape(-1, 3).copy()
    uv = mesh.face_vertex_uv.reshape(-1, 3, 2).copy()
    faces[5] = faces[5][[0, 2, 1]]
    uv[5] = uv[5][[0, 2, 1]]
    broken = mesh.replace(face_vertex_indices=faces.reshape(-1), face_vertex_uv=uv.reshape(-1, 2))
    repaired = prepare_mesh(broken).mesh
    np.testing.assert_array_equal(repaired.face_vertex_indices, mesh.face_vertex_indices)
    np.testing.assert_array_equal(repaired.face_vertex_uv, mesh.face_vertex_uv)


def test_duplicate_faces_are_removed():
    mesh = ClothMesh.from_triangles(SQUARE, [[0, 1, 2], [0, 2, 3], [2, 0, 1]], source="cloth.obj")
    prepared = prepare_mesh(mesh)
    assert prepared.mesh.face_count == 2
    assert "faces 2 duplicate earlier faces (face 2 repeats face 0)" in prepared.warnings[0]


def test_zero_area_faces_are_removed():
    pos = np.vstack([SQUARE, [[2, 0, 0]]])
    mesh = ClothMesh.from_triangles(pos, [[0, 1, 2], [0, 2, 3], [0, 1, 4]], source="cloth.obj")  # collinear
    prepared = prepare_mesh(mesh)
    assert prepared.mesh.face_count == 2
    assert any("faces 2 have zero area" in w for w in prepared.warnings)
    assert any("vertices 4 belong to no face" in w for w in prepared.warnings)
    assert prepared.vertex_map.tolist() == [0, 1, 2, 3, -1]


def test_zero_length_edges_are_collapsed_by_welding():
    # vertex 4 duplicates vertex 2: the quad (0,1,2,4,3) has a zero-length edge 2-4
    pos = np.vstack([SQUARE, SQUARE[2:3]])
    mesh = ClothMesh.from_faces(pos, [[0, 1, 2, 4, 3]], source="cloth.obj")
    prepared = prepare_mesh(mesh)
    assert prepared.welded == 1
    assert prepared.mesh.face_vertex_indices.tolist() == [0, 1, 2, 3]
    assert "zero-length edges" in prepared.warnings[0]
    assert prepared.vertex_map.tolist() == [0, 1, 2, 3, 2]


def test_uv_seam_vertices_are_welded_silently():
    # two quads with duplicated seam vertices (as a UV seam exports them)
    pos = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [1, 0, 0], [2, 0, 0], [2, 1, 0], [1, 1, 0]], float)
    mesh = ClothMesh.from_faces(pos, [[0, 1, 2, 3], [4, 5, 6, 7]], source="cloth.obj")
    prepared = prepare_mesh(mesh)
    assert prepared.warnings == []
    assert prepared.welded == 2 and prepared.mesh.vertex_count == 6
    assert prepared.mesh.face_vertex_indices.tolist() == [0, 1, 2, 3, 1, 4, 5, 2]


def test_weld_tolerance_is_relative_to_the_bounding_box():
    pos = np.vstack([SQUARE, SQUARE[1:2] + [0, 1e-4, 0]])
    mesh = ClothMesh.from_faces(pos, [[0, 1, 2, 3], [4, 1, 0]], source="cloth.obj")
    assert prepare_mesh(mesh, weld=1e-6).welded == 0
    # at 1e-3 of the diagonal the near-duplicate merges; the second face degenerates
    prepared = prepare_mesh(mesh, weld=1e-3)
    assert prepared.welded == 1 and prepared.mesh.face_count == 1


def test_sliver_triangles_warn_and_fail_under_strict():
    pos = np.array([[0, 0, 0], [1, 0, 0], [0.5, 0.005, 0], [0.5, -1, 0]], float)
    mesh = ClothMesh.from_triangles(pos, [[0, 1, 2], [0, 3, 1]], source="cloth.obj")
    prepared = prepare_mesh(mesh)
    assert any("faces 0 are slivers" in w for w in prepared.warnings)
    with pytest.raises(MeshError, match="slivers.*--strict"):
        prepare_mesh(mesh, strict=True)
