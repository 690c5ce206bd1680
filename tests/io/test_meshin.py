"""read_mesh: every format, read back from files written by meshio/trimesh/pxr or by hand."""

from __future__ import annotations

import base64
import json
import os
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from clothtool.errors import FormatError, MeshError
from clothtool.io.meshin import SUPPORTED_SUFFIXES, obj, read_mesh

# The garment every format test writes: a unit quad and a triangle sharing its edge 1-2.
POS = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0]], np.float64)
QUAD, TRI = [0, 1, 2, 3], [1, 4, 2]
PIN = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
UV = POS[:, :2] * 0.5  # per-vertex UVs where a format stores them per vertex


@pytest.fixture
def sub(tmp_path):
    path = tmp_path / "sub"
    path.mkdir()
    return path


def check_quad_tri(mesh, pos=POS):
    """The shared round-trip check: positions, and the quad kept as a quad, in file order."""
    np.testing.assert_allclose(mesh.vertex_pos, pos, atol=1e-6)
    assert mesh.face_vertex_counts.tolist() == [4, 3]
    assert mesh.face_vertex_indices.tolist() == QUAD + TRI
    assert mesh.face_vertex_indices.dtype == np.int64
    assert mesh.vertex_pos.dtype == np.float32


def one_line_error(excinfo, *parts):
    message = str(excinfo.value)
    assert "\n" not in message and "Traceback" not in message
    for part in parts:
        assert part in message, message
    return message


# ---------------------------------------------------------------------------------------------
# general


def test_supported_suffixes():
    assert SUPPORTED_SUFFIXES == (".obj", ".ply", ".off", ".stl", ".gltf", ".glb", ".usd", ".usda", ".usdc", ".usdz")


def test_missing_file(sub):
    path = sub / "shirt.obj"
    with pytest.raises(MeshError) as excinfo:
        read_mesh(path)
    assert str(excinfo.value) == f"{path}: file not found; check the path"


def test_unknown_suffix(sub):
    path = sub / "shirt.fbx"
    path.write_text("whatever")
    with pytest.raises(FormatError) as excinfo:
        read_mesh(path)
    one_line_error(excinfo, str(path), "'.fbx'", ".obj", ".usdz")


def test_prim_on_a_format_without_prims(sub):
    path = sub / "shirt.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(MeshError) as excinfo:
        read_mesh(path, prim="/shirt")
    one_line_error(excinfo, "only USD files have prims")


def test_source_is_the_path_as_given(sub):
    path = sub / "shirt.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert read_mesh(str(path)).source == str(path)
    assert read_mesh(path).source == str(path)


def test_libraries_load_lazily():
    import clothtool

    code = "import sys, clothtool.io.meshin; print(sorted({'meshio', 'trimesh', 'pxr'} & set(sys.modules)))"
    paths = [str(Path(clothtool.__file__).parents[1]), os.environ.get("PYTHONPATH", "")]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, paths))}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env).stdout
    assert out.strip() == "[]"


# ---------------------------------------------------------------------------------------------
# OBJ

OBJ_TEXT = """\
# exported by hand
mtllib shirt.mtl
o shirt
v 0 0 0 1 0 0
v 1 0 0 0 1 0
v 1 1 0 0 0 1
v 0 1 0 0.5 0.5 0.5
v 2 0 0 1 1 1
vt 0 0
vt 0.5 0
vt 0.5 0.5
vt 0 0.5
vt 1 0
vn 0 0 1
g front
usemtl cotton
s off
f 1/1/1 2/2/1 3/3/1 4/4/1
f 2/2/1 5/5/1 3/3/1
l 1 2
"""


def test_obj_quad_triangle_uv_and_colour(sub):
    path = sub / "shirt.obj"
    path.write_text(OBJ_TEXT)
    mesh = read_mesh(path)
    check_quad_tri(mesh)
    np.testing.assert_allclose(mesh.face_vertex_uv, UV[QUAD + TRI])
    assert mesh.face_vertex_uv.dtype == np.float32
    np.testing.assert_allclose(mesh.vertex_attrs["color_r"], [1, 0, 0, 0.5, 1])
    np.testing.assert_allclose(mesh.vertex_attrs["color_g"], [0, 1, 0, 0.5, 1])
    np.testing.assert_allclose(mesh.vertex_attrs["color_b"], [0, 0, 1, 0.5, 1])
    assert mesh.meters_per_unit is None and mesh.up_axis is None


@pytest.mark.parametrize(
    "faces, has_uv",
    [
        ("f 1 2 3 4\nf 2 5 3\n", False),
        ("f 1/1 2/2 3/3 4/4\nf 2/2 5/5 3/3\n", True),
        ("f 1//1 2//1 3//1 4//1\nf 2//1 5//1 3//1\n", False),
        ("f -5/-5 -4/-4 -3/-3 -2/-2\nf -4/-4 -1/-1 -3/-3\n", True),
        ("f\t1/1/1  2/2/1 3/3/1 4/4/1   \r\nf 2/2/1 5/5/1 3/3/1\r\n", True),
    ],
    ids=["a", "a/b", "a//c", "negative", "tabs-crlf"],
)
def test_obj_face_forms(sub, faces, has_uv):
    path = sub / "shirt.obj"
    vertices = "".join(f"v {x:g} {y:g} {z:g}\n" for x, y, z in POS)
    uvs = "".join(f"vt {u:g} {v:g}\n" for u, v in UV)
    path.write_text(vertices + uvs + "vn 0 0 1\n" + faces)
    mesh = read_mesh(path)
    check_quad_tri(mesh)
    assert "color_r" not in mesh.vertex_attrs
    if has_uv:
        np.testing.assert_allclose(mesh.face_vertex_uv, UV[QUAD + TRI])
    else:
        assert mesh.face_vertex_uv is None


def test_obj_that_needs_the_line_parser_reads_the_same(sub):
    """Indented lines, comments after statements and a byte order mark: the slow path."""
    plain, awkward = sub / "plain.obj", sub / "awkward.obj"
    plain.write_text(OBJ_TEXT)
    lines = [f"  {line}  # note" if line.startswith(("v", "f")) else line for line in OBJ_TEXT.splitlines()]
    awkward.write_bytes(b"\xef\xbb\xbf" + "\n".join(lines).encode())
    assert obj._parse_obj_fast(awkward.read_bytes()[3:]) is None
    want, got = read_mesh(plain), read_mesh(awkward)
    check_quad_tri(got)
    np.testing.assert_array_equal(got.face_vertex_uv, want.face_vertex_uv)
    for name in ("color_r", "color_g", "color_b"):
        np.testing.assert_array_equal(got.vertex_attrs[name], want.vertex_attrs[name])


def test_obj_negative_indices_count_from_the_vertices_read_so_far(sub):
    path = sub / "two.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 5 0 0\nv 6 0 0\nv 5 1 0\nv 5 5 5\nf -4 -3 -2\n")
    mesh = read_mesh(path)
    assert mesh.face_vertex_indices.tolist() == [0, 1, 2, 3, 4, 5]


def test_obj_polygons_w_and_vt_w_and_continuation(sub):
    path = sub / "poly.obj"
    path.write_text(
        "v 0 0 0 1\nv 1 0 0 1\nv 2 1 0 1\nv 1 2 0 1\nv 0 1 0 1\n"
        "vt 0 0 0\nvt 1 0 0\nvt 1 1 0\nvt 0.5 1 0\nvt 0 1 0\n"
        "f 1/1 2/2 \\\n 3/3 \\\n 4/4 5/5\n"
    )
    mesh = read_mesh(path)
    assert mesh.face_vertex_counts.tolist() == [5]
    assert mesh.face_vertex_indices.tolist() == [0, 1, 2, 3, 4]
    np.testing.assert_allclose(mesh.vertex_pos[2], [2, 1, 0])
    np.testing.assert_allclose(mesh.face_vertex_uv[3], [0.5, 1])


def test_obj_uv_only_when_every_corner_has_one(sub):
    path = sub / "mixed.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\nf 2 4 3\n")
    mesh = read_mesh(path)
    assert mesh.face_vertex_uv is None
    assert mesh.face_vertex_indices.tolist() == [0, 1, 2, 1, 3, 2]


def test_obj_colour_only_when_every_vertex_has_one(sub):
    path = sub / "mixed.obj"
    path.write_text("v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0 0 1 0\nf 1 2 3\n")
    mesh = read_mesh(path)
    assert mesh.vertex_attrs == {}
    np.testing.assert_allclose(mesh.vertex_pos, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])


def test_obj_out_of_range_indices_are_returned_raw(sub):
    path = sub / "bad_index.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\nf -1 -2 -7\n")
    mesh = read_mesh(path)
    assert mesh.face_vertex_indices.tolist() == [0, 1, 8, 2, 1, -4]


@pytest.mark.parametrize(
    "text",
    [
        OBJ_TEXT,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\nv 2 2 2\nf 1/-3 4/-1 3/-2\n",
        "v 0 0 0 1\nv 1 0 0 1\nv 0 1 0 1\nvt 0\nvt 1\nvt 0.5\nf 1/1 2/2 3/3\nf 3/3 2/2 1/1\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1//1 2//1 3//1\nf 2//1 4//1 3//1\n",
        "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\no b\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf -3 -2 -1\nf 1 5 9\n",
    ],
)
def test_obj_fast_parser_matches_the_line_parser(text):
    data = text.encode()
    fast = obj._parse_obj_fast(data)
    assert fast is not None, "well-formed files must take the vectorised path"
    slow = obj._parse_obj_lines(data, "x.obj")
    for got, want in zip(fast, slow):
        if want is None:
            assert got is None
        else:
            np.testing.assert_array_equal(np.asarray(got), want)


@pytest.mark.parametrize(
    "text, line, reason",
    [
        ("v 0 0 0\nv 1 0 0\nf 1 0 2\n", 3, "index 0"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\n# comment\nf 1 x 3\n", 5, "'f 1 x 3' is not a face"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2", 4, "at least 3 vertices"),
        ("v 0 0 0\nv 1 0\n", 2, "is not a vertex"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/2\n", 5, "UV index 2 is out of range"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/2/3/4 2 3\n", 4, "is not a face"),
        ("v 0 0 0\n\x89PNG\x00\x01\x02\nf 1 2 3\n", 2, "not an OBJ statement"),
    ],
    ids=["index-0", "garbage-face", "truncated", "short-vertex", "uv-range", "four-slashes", "binary"],
)
def test_obj_errors_name_the_line(sub, text, line, reason):
    path = sub / "bad.obj"
    path.write_bytes(text.encode("latin-1"))
    with pytest.raises(FormatError) as excinfo:
        read_mesh(path)
    message = one_line_error(excinfo, str(path), "not a valid OBJ file", f"line {line}:", reason, "re-export")
    assert message.startswith(f"{path}: ")


def test_obj_without_faces(sub):
    path = sub / "points.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\np 3\n")
    with pytest.raises(MeshError) as excinfo:
        read_mesh(path)
    assert str(excinfo.value) == f"{path}: mesh has no faces; export the garment as a polygon mesh"


# ---------------------------------------------------------------------------------------------
# PLY, OFF, STL


def meshio_quad_tri(**point_data):
    import meshio

    cells = [("quad", np.array([QUAD], np.int32)), ("triangle", np.array([TRI], np.int32))]
    return meshio.Mesh(POS, cells, point_data=point_data)


@pytest.mark.parametrize("binary", [False, True], ids=["ascii", "binary"])
def test_ply_from_meshio(sub, binary):
    path = sub / "shirt.ply"
    red = np.array([0, 255, 128, 1, 2], np.uint8)
    mesh_in = meshio_quad_tri(
        pin=PIN.astype(np.float32), stiffness=np.arange(5, dtype=np.int32), red=red,
        green=np.zeros(5, np.uint8), blue=np.full(5, 255, np.uint8),
    )
    mesh_in.write(path, binary=binary)
    mesh = read_mesh(path)
    check_quad_tri(mesh)
    np.testing.assert_allclose(mesh.vertex_attrs["pin"], PIN)
    np.testing.assert_allclose(mesh.vertex_attrs["stiffness"], [0, 1, 2, 3, 4])
    np.testing.assert_allclose(mesh.vertex_attrs["color_r"], red / 255.0, atol=1e-6)
    np.testing.assert_allclose(mesh.vertex_attrs["color_b"], 1.0)
    assert sorted(mesh.vertex_attrs) == ["color_b", "color_g", "color_r", "pin", "stiffness"]
    assert mesh.face_vertex_uv is None


def test_ply_binary_uchar_colours_vertex_index_and_uv(sub):
    """Blender-style binary PLY: `uchar` colours (meshio reads them as int8), per-vertex s/t,
    and a face list called `vertex_index`."""
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment by hand\nelement vertex 5\n"
        "property float x\nproperty float y\nproperty float z\nproperty float s\nproperty float t\n"
        "property uchar red\nproperty uchar green\nproperty uchar blue\n"
        "element face 2\nproperty list uchar uint vertex_index\nend_header\n"
    )
    body = b"".join(
        struct.pack("<5f3B", *POS[i], *UV[i], 200, 100, 255) for i in range(5)
    ) + struct.pack("<B4I", 4, *QUAD) + struct.pack("<B3I", 3, *TRI)
    path = sub / "blender.ply"
    path.write_bytes(header.encode() + body)
    mesh = read_mesh(path)
    check_quad_tri(mesh)
    np.testing.assert_allclose(mesh.vertex_attrs["color_r"], 200 / 255, atol=1e-6)
    np.testing.assert_allclose(mesh.vertex_attrs["color_b"], 1.0)
    np.testing.assert_allclose(mesh.face_vertex_uv, UV[QUAD + TRI], atol=1e-6)
    assert "s" not in mesh.vertex_attrs and "t" not in mesh.vertex_attrs


def test_ply_truncated_and_garbage(sub):
    good = sub / "good.ply"
    meshio_quad_tri(pin=PIN.astype(np.float32)).write(good, binary=True)
    truncated = sub / "truncated.ply"
    truncated.write_bytes(good.read_bytes()[:-10])
    with pytest.raises(FormatError) as excinfo:
        read_mesh(truncated)
    one_line_error(excinfo, str(truncated), "not a valid PLY file", "re-export")
    garbage = sub / "garbage.ply"
    garbage.write_bytes(b"\x00\x01garbage" * 20)
    with pytest.raises(FormatError) as excinfo:
        read_mesh(garbage)
    one_line_error(excinfo, "not a valid PLY file", "end_header")


def test_ply_face_properties_meshio_cannot_read(sub):
    path = sub / "meshlab.ply"
    path.write_text(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nproperty list uchar float texcoord\n"
        "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 6 0 0 1 0 0 1\n"
    )
    with pytest.raises(FormatError) as excinfo:
        read_mesh(path)
    one_line_error(excinfo, "face property 'texcoord' is not supported", "re-export without per-face UVs")


def test_ply_point_cloud_has_no_faces(sub):
    import meshio

    path = sub / "cloud.ply"
    meshio.Mesh(POS, []).write(path, binary=False)
    with pytest.raises(MeshError, match="mesh has no faces"):
        read_mesh(path)


def test_off_keeps_quads(sub):
    path = sub / "shirt.off"
    path.write_text(
        "OFF\n# a quad and a triangle\n5 2 0\n"
        + "".join(f"{x:g} {y:g} {z:g}\n" for x, y, z in POS)
        + "4 0 1 2 3\n3 1 4 2  255 0 0\n"
    )
    check_quad_tri(read_mesh(path))


def test_off_from_meshio_and_coff_colours(sub):
    import meshio

    path = sub / "tris.off"
    meshio.write_points_cells(path, POS, [("triangle", np.array([[0, 1, 2], [0, 2, 3], TRI]))])
    mesh = read_mesh(path)
    np.testing.assert_allclose(mesh.vertex_pos, POS)
    assert mesh.face_vertex_indices.tolist() == [0, 1, 2, 0, 2, 3] + TRI

    path = sub / "colour.off"
    path.write_text("COFF 3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 51 255\n3 0 1 2\n")
    mesh = read_mesh(path)
    np.testing.assert_allclose(mesh.vertex_attrs["color_r"], [1, 0, 0])
    np.testing.assert_allclose(mesh.vertex_attrs["color_b"], [0, 0, 0.2], atol=1e-6)


def test_off_truncated(sub):
    path = sub / "cut.off"
    path.write_text("OFF\n5 2 0\n0 0 0\n1 0 0\n1 1 0\n")
    with pytest.raises(FormatError) as excinfo:
        read_mesh(path)
    one_line_error(excinfo, "not a valid OFF file", "truncated")


@pytest.mark.parametrize("binary", [False, True], ids=["ascii", "binary"])
def test_stl_from_meshio(sub, binary):
    import meshio

    path = sub / "shirt.stl"
    triangles = np.array([[0, 1, 2], [0, 2, 3], TRI])
    meshio.write_points_cells(path, POS, [("triangle", triangles)], binary=binary)
    mesh = read_mesh(path)
    # STL stores each corner separately; equal corners come back merged, in first-seen order.
    np.testing.assert_allclose(mesh.vertex_pos, POS[[0, 1, 2, 3, 4]])
    assert mesh.face_vertex_counts.tolist() == [3, 3, 3]
    assert mesh.face_vertex_indices.tolist() == [0, 1, 2, 0, 2, 3, 1, 4, 2]


def test_stl_truncated(sub):
    import meshio

    good = sub / "good.stl"
    meshio.write_points_cells(good, POS, [("triangle", np.array([[0, 1, 2], TRI]))], binary=True)
    path = sub / "cut.stl"
    path.write_bytes(good.read_bytes()[:-20])
    with pytest.raises(FormatError) as excinfo:
        read_mesh(path)
    one_line_error(excinfo, "not a valid STL file", "truncated binary STL")


# ---------------------------------------------------------------------------------------------
# glTF / GLB


def trimesh_glb(sub, name="shirt.glb"):
    """A GLB written by trimesh: two triangles with UVs and a `_PIN` attribute, translated."""
    import trimesh

    faces = np.array([[0, 1, 2], [0, 2, 3], TRI])
    tm = trimesh.Trimesh(POS, faces, process=False, visual=trimesh.visual.TextureVisuals(uv=UV))
    tm.vertex_attributes["_PIN"] = PIN.astype(np.float32)
    scene = trimesh.Scene()
    scene.add_geometry(tm, node_name="shirt", transform=trimesh.transformations.translation_matrix([0, 0, 5]))
    path = sub / name
    path.write_bytes(scene.export(file_type="glb"))
    return path


def test_glb_from_trimesh_uv_custom_attribute_and_transform(sub):
    mesh = read_mesh(trimesh_glb(sub))
    np.testing.assert_allclose(mesh.vertex_pos, POS + [0, 0, 5])
    assert mesh.face_vertex_counts.tolist() == [3, 3, 3]
    assert mesh.face_vertex_indices.tolist() == [0, 1, 2, 0, 2, 3, 1, 4, 2]
    np.testing.assert_allclose(mesh.face_vertex_uv, UV[[0, 1, 2, 0, 2, 3, 1, 4, 2]], atol=1e-6)
    np.testing.assert_allclose(mesh.vertex_attrs["pin"], PIN)
    assert "_PIN" not in mesh.vertex_attrs


def test_glb_vertex_colours_from_trimesh(sub):
    import trimesh

    colours = np.array([[255, 0, 0, 255], [0, 255, 0, 255], [0, 0, 255, 255], [51, 51, 51, 255], [255] * 4], np.uint8)
    tm = trimesh.Trimesh(POS, [[0, 1, 2], TRI], process=False, vertex_colors=colours)
    path = sub / "colour.glb"
    path.write_bytes(tm.export(file_type="glb"))
    mesh = read_mesh(path)
    np.testing.assert_allclose(mesh.vertex_attrs["color_r"], [1, 0, 0, 0.2, 1], atol=1e-6)
    np.testing.assert_allclose(mesh.vertex_attrs["color_g"], [0, 1, 0, 0.2, 1], atol=1e-6)
    assert mesh.face_vertex_uv is None


def gltf_document(nodes):
    """A .gltf (JSON, data-URI buffer) as Blender writes it: no material, TEXCOORD_0 with a
    top-left origin, COLOR_0 as normalised uint16 and a `_PIN` attribute; two triangles."""
    grey = [32768, 32768, 32768, 65535]
    arrays = [  # (data, componentType, type): POSITION, indices, TEXCOORD_0, COLOR_0, _PIN
        (POS.astype(np.float32), 5126, "VEC3"),
        (np.array([0, 1, 2, 0, 2, 3], np.uint16), 5123, "SCALAR"),
        (np.column_stack((UV[:, 0], 1 - UV[:, 1])).astype(np.float32), 5126, "VEC2"),
        (np.array([[65535, 0, 0, 65535]] * 3 + [grey, [0, 0, 0, 0]], np.uint16), 5123, "VEC4"),
        (PIN.astype(np.float32), 5126, "SCALAR"),
    ]
    buffer, views, accessors = b"", [], []
    for index, (array, component, kind) in enumerate(arrays):
        views.append({"buffer": 0, "byteOffset": len(buffer), "byteLength": array.nbytes})
        accessors.append({"bufferView": index, "componentType": component, "count": len(array), "type": kind})
        buffer += array.tobytes() + b"\x00" * (-array.nbytes % 4)
    accessors[0].update(min=[0, 0, 0], max=[2, 1, 0])
    accessors[3]["normalized"] = True
    uri = "data:application/octet-stream;base64," + base64.b64encode(buffer).decode()
    attributes = {"POSITION": 0, "TEXCOORD_0": 2, "COLOR_0": 3, "_PIN": 4}
    return {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": [{"primitives": [{"attributes": attributes, "indices": 1}]}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(buffer), "uri": uri}],
    }


def test_gltf_without_material_keeps_uv_and_uint16_colours(sub):
    path = sub / "blender.gltf"
    path.write_text(json.dumps(gltf_document([{"mesh": 0}])))
    mesh = read_mesh(path)
    np.testing.assert_allclose(mesh.vertex_pos, POS)
    assert mesh.face_vertex_indices.tolist() == [0, 1, 2, 0, 2, 3]
    # trimesh flips V to a lower-left origin, like OBJ and USD
    np.testing.assert_allclose(mesh.face_vertex_uv, UV[[0, 1, 2, 0, 2, 3]], atol=1e-6)
    np.testing.assert_allclose(mesh.vertex_attrs["color_r"], [1, 1, 1, 32768 / 65535, 0], atol=1e-6)
    np.testing.assert_allclose(mesh.vertex_attrs["color_g"], [0, 0, 0, 32768 / 65535, 0], atol=1e-6)
    np.testing.assert_allclose(mesh.vertex_attrs["pin"], PIN)


def test_gltf_nodes_are_concatenated_and_mirrors_flip_winding(sub):
    path = sub / "two.gltf"
    path.write_text(json.dumps(gltf_document([{"mesh": 0}, {"mesh": 0, "scale": [-1, 1, 1]}])))
    mesh = read_mesh(path)
    assert mesh.vertex_count == 10
    np.testing.assert_allclose(mesh.vertex_pos[5:], POS * [-1, 1, 1])
    assert mesh.face_vertex_indices.tolist() == [0, 1, 2, 0, 2, 3, 5, 7, 6, 5, 8, 7]
    np.testing.assert_allclose(mesh.vertex_attrs["pin"], np.tile(PIN, 2))


def test_glb_truncated_and_garbage(sub):
    good = trimesh_glb(sub)
    cut = sub / "cut.glb"
    cut.write_bytes(good.read_bytes()[:-40])
    with pytest.raises(FormatError) as excinfo:
        read_mesh(cut)
    one_line_error(excinfo, str(cut), "not a valid GLB file", "truncated")
    garbage = sub / "garbage.glb"
    garbage.write_bytes(b"\x00\x01\x02 not a glb" * 10)
    with pytest.raises(FormatError) as excinfo:
        read_mesh(garbage)
    one_line_error(excinfo, "not a valid GLB file")
    garbage_json = sub / "garbage.gltf"
    garbage_json.write_text('{"asset": {"version": "2.0"}, "meshes": [')
    with pytest.raises(FormatError) as excinfo:
        read_mesh(garbage_json)
    one_line_error(excinfo, "not a valid GLTF file")


def test_gltf_with_a_missing_buffer_file(sub):
    import trimesh

    files = trimesh.Trimesh(POS, [TRI], process=False).export(file_type="gltf")
    for name, data in files.items():
        if not name.endswith(".bin"):
            (sub / name).write_bytes(data)
    missing = next(name for name in files if name.endswith(".bin"))
    with pytest.raises(MeshError) as excinfo:
        read_mesh(sub / "model.gltf")
    one_line_error(excinfo, f"cannot read {missing}", "check that it exists")


@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_gltf_is_metres_and_y_up_by_specification(sub, suffix):
    if suffix == ".glb":
        path = trimesh_glb(sub)
    else:
        path = sub / "blender.gltf"
        path.write_text(json.dumps(gltf_document([{"mesh": 0}])))
    mesh = read_mesh(path)
    assert mesh.meters_per_unit == 1.0
    assert mesh.up_axis == "Y"


def test_glb_without_meshes_has_no_faces(sub):
    path = sub / "empty.gltf"
    path.write_text(json.dumps({"asset": {"version": "2.0"}, "scenes": [{"nodes": []}], "scene": 0}))
    with pytest.raises(MeshError, match="mesh has no faces"):
        read_mesh(path)


# ---------------------------------------------------------------------------------------------
# USD


def usd_stage(path, *, second_mesh=False, orientation=None, st_interpolation="faceVarying", units=True):
    """/root (Xform, translated by (0,0,10)) / cloth (quad + triangle, pin, st, displayColor)."""
    from pxr import Gf, Sdf, Usd, UsdGeom, Vt

    stage = Usd.Stage.CreateNew(str(path))
    if units:
        UsdGeom.SetStageMetersPerUnit(stage, 0.01)
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/root").AddTranslateOp().Set(Gf.Vec3d(0, 0, 10))
    mesh = UsdGeom.Mesh.Define(stage, "/root/cloth")
    mesh.CreatePointsAttr([Gf.Vec3f(*p) for p in POS])
    mesh.CreateFaceVertexCountsAttr([4, 3])
    mesh.CreateFaceVertexIndicesAttr(QUAD + TRI)
    if orientation:
        mesh.CreateOrientationAttr(orientation)
    primvars = UsdGeom.PrimvarsAPI(mesh)
    primvars.CreatePrimvar("pin", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex).Set(PIN.tolist())
    primvars.CreatePrimvar("stretch", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.constant).Set([3.0])
    distance = primvars.CreatePrimvar("cloth:maxDistance", Sdf.ValueTypeNames.IntArray, UsdGeom.Tokens.varying)
    distance.Set([0, 7])  # indexed: vertex 0 -> 0, the others -> 7
    distance.SetIndices(Vt.IntArray([0, 1, 1, 1, 1]))
    st = primvars.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, st_interpolation)
    if st_interpolation == "faceVarying":  # indexed: 5 distinct UVs for 7 face corners
        st.Set([Gf.Vec2f(*uv) for uv in UV])
        st.SetIndices(Vt.IntArray(QUAD + TRI))
    else:
        st.Set([Gf.Vec2f(*uv) for uv in UV])
    mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex).Set([Gf.Vec3f(0.1 * i, 0.5, 1) for i in range(5)])
    if second_mesh:
        other = UsdGeom.Mesh.Define(stage, "/root/other")
        other.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
        other.CreateFaceVertexCountsAttr([3])
        other.CreateFaceVertexIndicesAttr([0, 1, 2])
    stage.GetRootLayer().Save()
    return path


@pytest.mark.parametrize("suffix", [".usda", ".usdc", ".usd"])
def test_usd_mesh_primvars_transform_and_units(sub, suffix):
    mesh = read_mesh(usd_stage(sub / f"shirt{suffix}"))
    check_quad_tri(mesh, pos=POS + [0, 0, 10])
    np.testing.assert_allclose(mesh.face_vertex_uv, UV[QUAD + TRI])
    np.testing.assert_allclose(mesh.vertex_attrs["pin"], PIN)
    np.testing.assert_allclose(mesh.vertex_attrs["color_r"], 0.1 * np.arange(5), atol=1e-6)
    np.testing.assert_allclose(mesh.vertex_attrs["color_g"], 0.5)
    np.testing.assert_allclose(mesh.vertex_attrs["maxDistance"], [0, 7, 7, 7, 7])  # namespace dropped
    assert "stretch" not in mesh.vertex_attrs  # constant interpolation is not per vertex
    assert mesh.meters_per_unit == pytest.approx(0.01)
    assert mesh.up_axis == "Z"


def test_usdz_package(sub):
    from pxr import Sdf, UsdUtils

    inner = usd_stage(sub / "shirt.usdc")
    path = sub / "shirt.usdz"
    assert UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(str(inner)), str(path))
    inner.unlink()
    mesh = read_mesh(path)
    check_quad_tri(mesh, pos=POS + [0, 0, 10])
    np.testing.assert_allclose(mesh.vertex_attrs["pin"], PIN)


def test_usd_vertex_uv_is_gathered_and_defaults_apply(sub):
    mesh = read_mesh(usd_stage(sub / "shirt.usda", st_interpolation="vertex", units=False))
    np.testing.assert_allclose(mesh.face_vertex_uv, UV[QUAD + TRI])
    # unauthored stage metadata: USD's fallbacks (centimetres, Y up)
    assert mesh.meters_per_unit == pytest.approx(0.01)
    assert mesh.up_axis == "Y"


def test_usd_left_handed_faces_come_back_counter_clockwise(sub):
    mesh = read_mesh(usd_stage(sub / "shirt.usda", orientation="leftHanded"))
    assert mesh.face_vertex_indices.tolist() == [0, 3, 2, 1, 1, 2, 4]
    np.testing.assert_allclose(mesh.face_vertex_uv, UV[[0, 3, 2, 1, 1, 2, 4]])


def test_usd_prim_selection(sub):
    path = usd_stage(sub / "two.usda", second_mesh=True)
    assert read_mesh(path).vertex_count == 5  # the first mesh in traversal order
    other = read_mesh(path, prim="/root/other")
    assert other.face_vertex_indices.tolist() == [0, 1, 2]
    np.testing.assert_allclose(other.vertex_pos[1], [1, 0, 10])
    with pytest.raises(MeshError) as excinfo:
        read_mesh(path, prim="/root")
    one_line_error(excinfo, "'/root' is not a UsdGeom.Mesh", "/root/cloth, /root/other")
    with pytest.raises(MeshError) as excinfo:
        read_mesh(path, prim="/root/sleeve")
    one_line_error(excinfo, "does not exist", "/root/cloth, /root/other")


def test_usd_time_samples_only(sub):
    from pxr import Gf, Usd, UsdGeom

    path = sub / "animated.usda"
    stage = Usd.Stage.CreateNew(str(path))
    op = UsdGeom.Xform.Define(stage, "/root").AddTranslateOp()
    op.Set(Gf.Vec3d(0, 1, 0), 3.0)
    op.Set(Gf.Vec3d(0, 9, 0), 8.0)
    mesh = UsdGeom.Mesh.Define(stage, "/root/cloth")
    mesh.CreatePointsAttr().Set([(0, 0, 0), (1, 0, 0), (0, 1, 0)], 3.0)
    mesh.CreatePointsAttr().Set([(0, 0, 5), (1, 0, 5), (0, 1, 5)], 8.0)
    mesh.CreateFaceVertexCountsAttr([3])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2])
    stage.GetRootLayer().Save()
    np.testing.assert_allclose(read_mesh(path).vertex_pos, [[0, 1, 0], [1, 1, 0], [0, 2, 0]])


def test_usd_without_mesh_prims(sub):
    from pxr import Usd, UsdGeom

    path = sub / "empty.usda"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.Xform.Define(stage, "/root")
    stage.GetRootLayer().Save()
    with pytest.raises(MeshError) as excinfo:
        read_mesh(path)
    one_line_error(excinfo, "no UsdGeom.Mesh prim")


def test_usd_truncated_and_garbage(sub):
    good = usd_stage(sub / "good.usda")
    cut = sub / "cut.usda"
    cut.write_text(good.read_text()[:-60])
    with pytest.raises(FormatError) as excinfo:
        read_mesh(cut)
    message = one_line_error(excinfo, str(cut), "not a valid USDA file", "re-export")
    assert "pxrInternal" not in message and "Error in" not in message
    garbage = sub / "garbage.usdc"
    garbage.write_bytes(b"\x00garbage" * 30)
    with pytest.raises(FormatError) as excinfo:
        read_mesh(garbage)
    one_line_error(excinfo, "not a valid USDC file")
