"""OFF.

Our own parser: meshio's OFF reader refuses any face that is not a triangle ("Can only read
triangular faces"), and its writer drops quads, so it cannot keep a quad garment.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from clothtool.io.meshin._common import _gather_uv, _invalid, _parse_floats, _parse_int, _snippet
from clothtool.mesh.clothmesh import ClothMesh

_OFF_HEADER = re.compile(r"(ST)?(C)?(N)?(4)?(n)?OFF$")


def read(source: str, prim: str | None) -> ClothMesh:
    text = Path(source).read_bytes().decode("utf-8", errors="replace")
    lines = [
        (number, tokens)
        for number, line in enumerate(text.splitlines(), 1)
        if (tokens := line.split("#", 1)[0].split())
    ]
    if not lines:
        raise _invalid(source, "the file is empty")
    number, tokens = lines[0]
    header = _OFF_HEADER.match(tokens[0])
    if header is None and not tokens[0].isdigit():
        raise _invalid(source, f"line {number}: '{_snippet(' '.join(tokens))}' is not an OFF header")
    flags = [group is not None for group in header.groups()] if header else [False] * 5
    has_st, has_color, has_normal, four_d, n_dim = flags
    if four_d or n_dim or "BINARY" in tokens:
        raise _invalid(source, f"line {number}: '{tokens[0]}' (4D, nD or binary OFF) is not supported")
    rest = lines[1:] if header else lines
    counts_tokens = tokens[1:] if header and len(tokens) > 1 else (rest.pop(0)[1] if rest else [])
    try:
        n_vertices, n_faces = int(counts_tokens[0]), int(counts_tokens[1])
    except (IndexError, ValueError):
        raise _invalid(source, "the vertex/face counts are missing") from None
    if len(rest) < n_vertices + n_faces:
        announced = f"{n_vertices} vertices and {n_faces} faces announced"
        raise _invalid(source, f"truncated: {announced}, {len(rest)} lines found")

    table = []
    for number, tokens in rest[:n_vertices]:
        values = _parse_floats(tokens)
        if values is None or len(values) < 3 or (table and len(values) != len(table[0])):
            raise _invalid(source, f"line {number}: '{_snippet(' '.join(tokens))}' is not a vertex")
        table.append(values)
    table = np.array(table, np.float64).reshape(n_vertices, -1)
    extra = table.shape[1] - 3 - 3 * has_normal - 2 * has_st if n_vertices else 0
    attrs = {}
    if has_color and extra in (3, 4):
        rgb = table[:, 3 + 3 * has_normal : 6 + 3 * has_normal]
        if rgb.size and rgb.max() > 1.0:  # COFF colours are 0..255 integers or 0..1 floats
            rgb = rgb / 255.0
        attrs = {"color_r": rgb[:, 0], "color_g": rgb[:, 1], "color_b": rgb[:, 2]}

    counts, indices = [], []
    for number, tokens in rest[n_vertices : n_vertices + n_faces]:
        face = [_parse_int(token) for token in tokens]
        size = face[0]
        if size is None or size < 3 or len(face) < size + 1 or None in face[1 : size + 1]:
            raise _invalid(source, f"line {number}: '{_snippet(' '.join(tokens))}' is not a face")
        counts.append(size)
        indices.extend(face[1 : size + 1])
    indices = np.array(indices, np.int64)
    face_uv = _gather_uv(table[:, -2:], indices) if has_st else None
    return ClothMesh(table[:, :3], np.array(counts, np.int32), indices, face_uv, attrs, source)


READERS = {".off": read}
