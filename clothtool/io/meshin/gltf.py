"""glTF / GLB through trimesh.

trimesh keeps TEXCOORD_0 only on primitives that have a material, and turns a COLOR_0
without one into uint8 by a plain cast (wrong for the normalised uint16 Blender writes).
So every primitive is pointed at one empty material before trimesh sees the file; then UVs
arrive in `visual.uv` (flipped to a lower-left origin) and the raw COLOR_0 accessor in
`visual.vertex_attributes["color"]`. Texture images are dropped on the way (not needed), and
nodes are renamed to their index so that the pieces can be put back in file order.

glTF fixes its units (metres) and up axis (+Y) by specification, so the mesh says so.
"""

from __future__ import annotations

import io
import json
import struct
from pathlib import Path

import numpy as np

from clothtool.io.meshin._common import _gather_uv, _invalid, _unit_color
from clothtool.mesh.clothmesh import ClothMesh

_GLB_MAGIC, _GLB_JSON, _GLB_BIN = b"glTF", 0x4E4F534A, 0x004E4942
_GLTF_METERS_PER_UNIT, _GLTF_UP_AXIS = 1.0, "Y"  # fixed by the glTF 2.0 specification


def read(source: str, prim: str | None) -> ClothMesh:
    import trimesh

    gltf, binary = _gltf_split(Path(source).read_bytes(), source)
    if not isinstance(gltf, dict):
        raise _invalid(source, "the JSON is not a glTF object")
    _check_buffer_uris(gltf, source)
    gltf["materials"] = [{}]
    for key in ("textures", "images", "samplers"):
        gltf.pop(key, None)
    for mesh in gltf.get("meshes", []):
        for primitive in mesh.get("primitives", []):
            primitive["material"] = 0
    for index, node in enumerate(gltf.get("nodes", [])):
        node["name"] = str(index)  # trimesh walks nodes last-first; names let us restore file order
    blob, file_type = _gltf_join(gltf, binary)
    scene = trimesh.load(
        io.BytesIO(blob),
        file_type=file_type,
        resolver=trimesh.resolvers.FilePathResolver(source),
        force="scene",
        process=False,
    )
    pieces = []
    # A node with several primitives gets child frames "<node>_<random id>", in primitive order.
    for node in sorted(scene.graph.nodes_geometry, key=_gltf_node_index):
        matrix, name = scene.graph[node]
        geometry = scene.geometry[name]
        if isinstance(geometry, trimesh.Trimesh) and len(geometry.faces):
            pieces.append(_gltf_piece(geometry, np.asarray(matrix, np.float64)))
    return _concatenate(pieces, source)


def _check_buffer_uris(gltf: dict, source: str) -> None:
    """External buffers must lie beside the .gltf (or below its folder): a URI that climbs out
    of it would read an unrelated file."""
    folder = Path(source).resolve().parent
    for index, buffer in enumerate(gltf.get("buffers") or []):
        uri = buffer.get("uri") if isinstance(buffer, dict) else None
        if not isinstance(uri, str) or uri.startswith("data:"):
            continue
        if not (folder / uri).resolve().is_relative_to(folder):
            raise _invalid(source, f"buffer {index} points outside the file's folder ('{uri}'); keep its .bin beside the .gltf")


def _gltf_node_index(frame) -> int:
    head = str(frame).split("_")[0]
    return int(head) if head.isdigit() else 1 << 62


def _gltf_split(data: bytes, source: str):
    """(glTF JSON as dict, BIN chunk or None) from a .gltf or .glb file's bytes."""
    if not data.startswith(_GLB_MAGIC):
        return json.loads(data.decode("utf-8")), None
    if len(data) < 20:
        raise _invalid(source, "truncated GLB header")
    _, version, length = struct.unpack_from("<4sII", data, 0)
    if version != 2:
        raise _invalid(source, f"GLB version {version}; only glTF 2.0 is supported")
    if length > len(data):
        raise _invalid(source, f"truncated: the header says {length} bytes, the file has {len(data)}")
    json_length, json_type = struct.unpack_from("<II", data, 12)
    if json_type != _GLB_JSON or 20 + json_length > length:
        raise _invalid(source, "the first GLB chunk is not JSON")
    gltf = json.loads(data[20 : 20 + json_length].decode("utf-8"))
    binary, offset = None, 20 + json_length
    if offset + 8 <= length:
        bin_length, bin_type = struct.unpack_from("<II", data, offset)
        if bin_type == _GLB_BIN:
            binary = data[offset + 8 : offset + 8 + bin_length]
            if len(binary) < bin_length:
                raise _invalid(source, "truncated BIN chunk")
    return gltf, binary


def _gltf_join(gltf: dict, binary: bytes | None) -> tuple[bytes, str]:
    text = json.dumps(gltf).encode("utf-8")
    if binary is None:
        return text, "gltf"
    text += b" " * (-len(text) % 4)
    binary += b"\x00" * (-len(binary) % 4)
    chunks = struct.pack("<II", len(text), _GLB_JSON) + text
    chunks += struct.pack("<II", len(binary), _GLB_BIN) + binary
    return _GLB_MAGIC + struct.pack("<II", 2, 12 + len(chunks)) + chunks, "glb"


def _gltf_piece(geometry, matrix: np.ndarray) -> dict:
    vertices = np.asarray(geometry.vertices, np.float64)
    faces = np.asarray(geometry.faces, np.int64)
    if np.linalg.det(matrix[:3, :3]) < 0:  # a mirroring node flips the winding (glTF spec)
        faces = faces[:, [0, 2, 1]]
    visual = geometry.visual
    uv = getattr(visual, "uv", None)
    stored = getattr(visual, "vertex_attributes", None)
    colors = None
    if stored is not None and "color" in stored:
        colors = np.asarray(stored["color"])
    elif getattr(visual, "kind", None) == "vertex":  # not reached while the material patch holds
        colors = np.asarray(visual.vertex_colors)
    attrs = {}
    if colors is not None and colors.ndim == 2 and colors.shape[1] >= 3 and len(colors) == len(vertices):
        for channel, column in zip("rgb", colors[:, :3].T):
            attrs[f"color_{channel}"] = _unit_color(column)
    for key, values in geometry.vertex_attributes.items():
        values = np.asarray(values)
        if key.startswith("_") and values.size == len(vertices):  # scalar custom attributes only
            attrs[key[1:].lower()] = values.reshape(-1).astype(np.float32)
    return {
        "pos": vertices @ matrix[:3, :3].T + matrix[:3, 3],
        "faces": faces,
        "uv": None if uv is None else _gather_uv(np.asarray(uv), faces.reshape(-1)),
        "attrs": attrs,
    }


def _concatenate(pieces: list[dict], source: str) -> ClothMesh:
    """One mesh from scene pieces. An attribute missing from a piece is 0 there (1 for
    colour, glTF's default white); UVs are kept only when every piece has them."""
    if not pieces:
        return ClothMesh(
            np.zeros((0, 3)), np.zeros(0), np.zeros(0), source=source,
            meters_per_unit=_GLTF_METERS_PER_UNIT, up_axis=_GLTF_UP_AXIS,
        )
    offsets = np.cumsum([0] + [len(piece["pos"]) for piece in pieces])
    names = list(dict.fromkeys(name for piece in pieces for name in piece["attrs"]))
    attrs = {
        name: np.concatenate([
            piece["attrs"].get(name, np.full(len(piece["pos"]), 1.0 if name.startswith("color_") else 0.0))
            for piece in pieces
        ])
        for name in names
    }
    uvs = [piece["uv"] for piece in pieces]
    return ClothMesh(
        vertex_pos=np.concatenate([piece["pos"] for piece in pieces]),
        face_vertex_counts=np.concatenate([np.full(len(piece["faces"]), 3) for piece in pieces]),
        face_vertex_indices=np.concatenate(
            [piece["faces"].reshape(-1) + offset for piece, offset in zip(pieces, offsets)]
        ),
        face_vertex_uv=None if any(uv is None for uv in uvs) else np.concatenate(uvs),
        vertex_attrs=attrs,
        source=source,
        meters_per_unit=_GLTF_METERS_PER_UNIT,
        up_axis=_GLTF_UP_AXIS,
    )


READERS = {".gltf": read, ".glb": read}
