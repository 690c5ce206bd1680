"""PLY through meshio.

meshio.read() prints the error and calls sys.exit(1) on a ReadError, so the per-format
reader (meshio.ply.read) is called instead: it raises.
"""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np

from clothtool.errors import FormatError
from clothtool.io.meshin._common import _gather_uv, _invalid, _meshio_polygons, _unit_color
from clothtool.mesh.clothmesh import ClothMesh

_PLY_UV_NAMES = (("s", "t"), ("u", "v"), ("texture_u", "texture_v"))
_PLY_FLOAT_TYPES = ("float", "float32", "double", "float64")


def read(source: str, prim: str | None) -> ClothMesh:
    import meshio

    data = Path(source).read_bytes()
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise _invalid(source, "no 'ply ... end_header' header")
    header = data[:end].decode("ascii", errors="replace")
    elements = _ply_elements(header)
    extra = [f"element '{name}'" for name in elements if name not in ("vertex", "face")]
    extra += [
        f"face property '{name}'"
        for _, name in elements.get("face", [])
        if name not in ("vertex_indices", "vertex_index")
    ]
    if extra:  # meshio fails on these (KeyError / "len() of unsized object")
        raise FormatError(
            f"{source}: PLY {extra[0]} is not supported (meshio reads vertex data and face vertex "
            "lists only); "
            "re-export without per-face UVs, colours or edges"
        )
    float_lists = [
        (name, kind) for kind, name in elements.get("face", [])
        if kind.startswith("list ") and kind.split()[-1] in _PLY_FLOAT_TYPES
    ]
    if float_lists:  # meshio would read them and the indices be silently truncated
        raise FormatError(
            f"{source}: PLY face property '{float_lists[0][0]}' is declared '{float_lists[0][1]}'; "
            "vertex indices must be an integer type (int, uint, ...), re-export the mesh"
        )
    # meshio only knows the face list as `vertex_indices`; some exporters write `vertex_index`.
    renamed = re.sub(r"(property list \S+ \S+ )vertex_index\b", r"\1vertex_indices", header)
    if renamed != header:
        data = renamed.encode("ascii", errors="replace") + data[end:]
    mesh = meshio.ply.read(io.BytesIO(data))

    declared = dict((name, kind) for kind, name in elements.get("vertex", []))
    n = len(mesh.points)
    counts, indices = _meshio_polygons(mesh.cells)
    columns = {}
    for name, values in mesh.point_data.items():
        values = np.asarray(values)
        if values.ndim == 1 and values.shape[0] == n and values.dtype.kind in "fiub":
            if declared.get(name) in ("uchar", "uint8") and values.dtype == np.int8:
                values = values.view(np.uint8)  # meshio's binary reader reads uchar as signed
            columns[name] = values
    uv_pair = next((pair for pair in _PLY_UV_NAMES if set(pair) <= columns.keys()), ())
    face_uv = _gather_uv(np.column_stack([columns[name] for name in uv_pair]), indices) if uv_pair else None
    attrs = {}
    for name, values in columns.items():
        if name in ("red", "green", "blue"):
            attrs[f"color_{name[0]}"] = _unit_color(values)
        elif name not in uv_pair:
            attrs[name] = values.astype(np.float32)
    return ClothMesh(mesh.points, counts, indices, face_uv, attrs, source)


def _ply_elements(header: str) -> dict[str, list[tuple[str, str]]]:
    """Element name -> [(declared type, property name)] from a PLY header."""
    elements: dict[str, list[tuple[str, str]]] = {}
    properties: list[tuple[str, str]] = []
    for line in header.splitlines():
        words = line.split()
        if words[:1] == ["element"] and len(words) >= 2:
            properties = elements.setdefault(words[1], [])
        elif words[:1] == ["property"] and len(words) >= 3:
            properties.append((" ".join(words[1:-1]), words[-1]))
    return elements


READERS = {".ply": read}
