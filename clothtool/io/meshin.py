"""Read a garment mesh file (OBJ, PLY, OFF, STL, glTF/GLB, USD) into a raw ClothMesh.

The readers do not weld, triangulate, reorder or repair anything: polygons keep their
size and faces keep the file's order, so that the cooker's checks report problems against
the file the user knows. Index ranges and NaN are the cooker's business too.

meshio, trimesh and pxr are imported inside the reader that needs them, so importing this
module costs only numpy.
"""

from __future__ import annotations

import io
import json
import os
import re
import struct
import warnings
from pathlib import Path

import numpy as np

from clothtool.errors import ClothtoolError, FormatError, MeshError
from clothtool.mesh.clothmesh import ClothMesh

_USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")


def read_mesh(path: str | os.PathLike, prim: str | None = None) -> ClothMesh:
    """Read the mesh in ``path``; ``prim`` picks a mesh prim in a USD file.

    Raises MeshError when the file is missing or has no faces, FormatError when its suffix
    is unknown or its content is not what the suffix says.
    """
    source = str(path)
    suffix = os.path.splitext(source)[1].lower()
    if not os.path.exists(source):
        raise MeshError(f"{source}: file not found; check the path")
    reader = _READERS.get(suffix)
    if reader is None:
        raise FormatError(
            f"{source}: unknown mesh file type '{suffix or '(no suffix)'}'; "
            f"use one of {', '.join(SUPPORTED_SUFFIXES)}"
        )
    if os.path.isdir(source):
        raise MeshError(f"{source}: is a directory; pass the mesh file inside it")
    if prim is not None and suffix not in _USD_SUFFIXES:
        raise MeshError(f"{source}: only USD files have prims; drop prim '{prim}' for a {suffix} file")
    try:
        mesh = reader(source, prim)
    except (ClothtoolError, MemoryError):
        raise
    except OSError as exc:  # also a glTF's missing .bin, which trimesh reports by bare name
        missing = isinstance(exc, FileNotFoundError)
        name = exc.filename or (exc.args[0] if missing and len(exc.args) == 1 else source)
        reason = exc.strerror or ("not found" if missing else str(exc))
        raise MeshError(
            f"{source}: cannot read {name} ({reason}); check that it exists and is readable"
        ) from exc
    except Exception as exc:  # library errors: meshio ReadError, trimesh, pxr Tf.ErrorException, ...
        raise _invalid(source, _first_line(exc)) from exc
    if mesh.face_count == 0:
        raise MeshError(f"{source}: mesh has no faces; export the garment as a polygon mesh")
    return mesh


# ---------------------------------------------------------------------------------------------
# shared helpers


def _format_name(source: str) -> str:
    return os.path.splitext(source)[1].lstrip(".").upper() or "mesh"


def _invalid(source: str, reason: str) -> FormatError:
    return FormatError(
        f"{source}: not a valid {_format_name(source)} file ({reason}); re-export it from your DCC"
    )


def _first_line(exc: BaseException) -> str:
    """The first meaningful line of a library exception, without pxr's C++ location prefix."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    if not lines:
        return type(exc).__name__
    line = lines[0]
    # pxr: "Error in 'pxrInternal_v0_26::Func' at line 48 in file /x/y.h : 'the message'"
    match = re.match(r"Error in '.*?' at line \d+ in file .*? : '(.*?)'?$", line)
    if match:
        line = match.group(1)
    line = re.sub(r"pxrInternal_\w+?__pxrReserved___*:*", "", line)
    if type(exc).__module__ == "builtins" and not isinstance(exc, (ValueError, OSError)):
        line = f"{type(exc).__name__}: {line}"  # IndexError('list index out of range') etc.
    return line[:200]


def _snippet(line: str) -> str:
    line = line.strip()
    if len(line) > 40:
        line = line[:37] + "..."
    return line.encode("ascii", "backslashreplace").decode("ascii")


def _unit_color(values: np.ndarray) -> np.ndarray:
    """Colour channel as float in [0,1]: integers are normalised by their type's maximum."""
    values = np.asarray(values)
    if values.dtype.kind in "iu":
        return values.astype(np.float32) / np.float32(np.iinfo(values.dtype).max)
    return values.astype(np.float32)


def _gather_uv(uv: np.ndarray, indices: np.ndarray) -> np.ndarray | None:
    """Per-vertex UVs as per-face-vertex UVs; None when an index is out of range (the cooker
    reports bad indices, so the UVs are simply dropped here)."""
    if indices.size and (indices.min() < 0 or indices.max() >= len(uv)):
        return None
    return np.asarray(uv, np.float32)[indices]


def _reverse_winding(counts: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Reverse every face's vertex order, keeping its first vertex: (a,b,c,d) -> (a,d,c,b)."""
    counts = np.asarray(counts, np.int64)
    starts = np.repeat(np.cumsum(counts) - counts, counts)
    within = np.arange(indices.size) - starts
    size = np.repeat(counts, counts)
    return indices[starts + (size - within) % size]


# ---------------------------------------------------------------------------------------------
# OBJ
#
# Our own parser: trimesh triangulates polygons on load, and meshio drops vertex colours and
# per-corner (vt) UVs. A vectorised pass handles well-formed files; anything it is unsure
# about goes to the line-by-line parser, which is the reference and names the bad line.

_OBJ_BLANKS = bytes.maketrans(b"\t\r", b"  ")
_OBJ_V, _OBJ_VT, _OBJ_F, _OBJ_SKIP, _OBJ_ODD = 1, 2, 3, 4, 5


def _read_obj(source: str, prim: str | None) -> ClothMesh:
    data = Path(source).read_bytes().removeprefix(b"\xef\xbb\xbf")  # UTF-8 byte order mark
    parsed = _parse_obj_fast(data)
    if parsed is None:
        parsed = _parse_obj_lines(data, source)
    pos, colors, uv_table, counts, vidx, vtidx = parsed
    attrs = {}
    if colors is not None:
        attrs = {"color_r": colors[:, 0], "color_g": colors[:, 1], "color_b": colors[:, 2]}
    face_uv = None
    if vtidx is not None:
        face_uv = np.asarray(uv_table, np.float32).reshape(-1, 2)[vtidx]
    return ClothMesh(
        vertex_pos=np.asarray(pos, np.float32).reshape(-1, 3),
        face_vertex_counts=counts,
        face_vertex_indices=vidx,
        face_vertex_uv=face_uv,
        vertex_attrs=attrs,
        source=source,
    )


def _obj_resolve(raw: np.ndarray, defined_before: np.ndarray) -> np.ndarray:
    """1-based / negative (relative to the elements defined so far) -> 0-based indices."""
    return np.where(raw > 0, raw - 1, defined_before + raw)


def _parse_obj_fast(data: bytes):
    """Vectorised OBJ parse; None when the file needs the line-by-line parser."""
    if b"\x00" in data:
        return None
    if b"\\" in data:
        data = re.sub(rb"\\[ \t]*\r?\n", b" ", data)
    if not data.endswith(b"\n"):
        data += b"\n"
    buf = np.frombuffer(data, np.uint8)
    ends = np.flatnonzero(buf == 10)
    starts = np.concatenate(([0], ends[:-1] + 1))
    c0 = buf[starts]
    c1 = buf[np.minimum(starts + 1, buf.size - 1)]
    c2 = buf[np.minimum(starts + 2, buf.size - 1)]
    space1 = (c1 == 32) | (c1 == 9) | (c1 == 13) | (c1 == 10) | (c1 == 35)  # 35: "v#" is "v"
    space2 = (c2 == 32) | (c2 == 9) | (c2 == 13) | (c2 == 10) | (c2 == 35)
    letter = ((c0 >= 65) & (c0 <= 90)) | ((c0 >= 97) & (c0 <= 122))
    kind = np.full(starts.size, _OBJ_ODD, np.int8)
    kind[letter | (c0 == 35) | (c0 == 10) | ((c0 == 13) & (c1 == 10))] = _OBJ_SKIP
    kind[(c0 == 118) & space1] = _OBJ_V
    kind[(c0 == 118) & (c1 == 116) & space2] = _OBJ_VT
    kind[(c0 == 102) & space1] = _OBJ_F
    odd = np.flatnonzero(kind == _OBJ_ODD)
    if odd.size > 1000:
        return None
    for line in odd:  # indented or blank-with-spaces lines: fine only when blank
        if data[starts[line] : ends[line]].strip():
            return None
        kind[line] = _OBJ_SKIP
    hashes = np.flatnonzero(buf == 35)
    if hashes.size:  # a comment after a statement: leave it to the line parser
        hash_lines = np.searchsorted(ends, hashes)
        if np.isin(kind[hash_lines], (_OBJ_V, _OBJ_VT, _OBJ_F)).any():
            return None

    change = np.flatnonzero(kind[1:] != kind[:-1]) + 1
    run_first = np.concatenate(([0], change))
    run_last = np.concatenate((change, [kind.size])) - 1
    payload: dict[int, list[bytes]] = {_OBJ_V: [], _OBJ_VT: [], _OBJ_F: []}
    for first, last in zip(run_first.tolist(), run_last.tolist()):
        if int(kind[first]) in payload:
            payload[int(kind[first])].append(data[starts[first] : ends[last] + 1])

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy < 2 only warns when np.fromstring meets junk
        try:
            pos = _obj_table(_obj_payload(payload[_OBJ_V], b"v"))
            uvs = _obj_table(_obj_payload(payload[_OBJ_VT], b"vt"))
            faces = _obj_faces(_obj_payload(payload[_OBJ_F], b"f"))
        except (ValueError, Warning):
            return None
    if faces is None or pos.shape[1] not in (3, 4, 6) or uvs.shape[1] not in (0, 1, 2, 3):
        return None
    if len(pos) != (kind == _OBJ_V).sum() or len(uvs) != (kind == _OBJ_VT).sum():
        return None  # a bare `v` line: loadtxt skips empty rows
    uvs = np.column_stack((uvs, np.zeros((len(uvs), 2))))[:, :2]  # vt u -> (u, 0)

    counts, v_raw, vt_raw = faces
    face_lines = np.flatnonzero(kind == _OBJ_F)
    v_before = np.cumsum(kind == _OBJ_V)[face_lines]
    if (v_raw == 0).any():
        return None
    vidx = _obj_resolve(v_raw, np.repeat(v_before, counts))
    vtidx = None
    if vt_raw is not None:
        vt_before = np.cumsum(kind == _OBJ_VT)[face_lines]
        vtidx = _obj_resolve(vt_raw, np.repeat(vt_before, counts))
        if (vt_raw == 0).any() or (vtidx < 0).any() or (vtidx >= len(uvs)).any():
            return None
    colors = pos[:, 3:6] if pos.shape[1] == 6 else None
    return pos[:, :3], colors, uvs, counts, vidx, vtidx


def _obj_payload(runs: list[bytes], keyword: bytes) -> bytes:
    """Runs of `keyword ...` lines -> their arguments, one line each, blanks as spaces."""
    text = (b"\n" + b"".join(runs)).replace(b"\n" + keyword, b"\n")  # only line starts
    return text[1:].translate(_OBJ_BLANKS)


def _obj_table(text: bytes) -> np.ndarray:
    """Rows of numbers (one per line, all the same length) -> (n, k) float64; (0, 0) if empty."""
    if not text.strip():
        return np.zeros((0, 0))
    return np.loadtxt(io.BytesIO(text), dtype=np.float64, comments=None, ndmin=2)


def _obj_faces(text: bytes):
    """Face lines (keyword removed) -> (counts, raw v indices, raw vt indices or None).

    None when some corner is not one of ``a``, ``a/b``, ``a/b/c``, ``a//c``.
    """
    if not text:
        return np.zeros(0, np.int32), np.zeros(0, np.int64), None
    if text.translate(None, b"0123456789+-/ \n") or text.startswith(b"/"):
        return None
    if any(bad in text for bad in (b" /", b"/ ", b"/\n", b"///")):
        return None  # an empty a/b/c field
    buf = np.frombuffer(text, np.uint8)
    signs = np.flatnonzero((buf == 43) | (buf == 45))
    if signs.size:  # np.fromstring reads a lone "-" as 0 and "- 2" as -2
        before = buf[np.maximum(signs - 1, 0)]
        after = buf[signs + 1]
        if ((after < 48) | (after > 57)).any() or not np.isin(before[signs > 0], (32, 10, 47)).all():
            return None
    sep = (buf == 32) | (buf == 10)
    corner_start = ~sep
    corner_start[1:] &= sep[:-1]
    corners = np.flatnonzero(corner_start)
    counts = np.diff(np.searchsorted(corners, np.flatnonzero(buf == 10)), prepend=0)
    if counts.size == 0 or counts.min() < 3:
        return None
    slashes = np.flatnonzero(buf == 47)
    per_corner = np.diff(np.searchsorted(slashes, corners), append=slashes.size)
    if b"//" in text:  # a//c: normals only, no UVs
        if (per_corner != 2).any() or text.count(b"//") != corners.size:
            return None
        numbers = np.fromstring(text.replace(b"//", b" "), dtype=np.int64, sep=" ")
        if numbers.size != 2 * corners.size:
            return None
        return counts.astype(np.int32), numbers[0::2], None
    if per_corner.max() > 2:
        return None
    numbers = np.fromstring(text.replace(b"/", b" "), dtype=np.int64, sep=" ")
    width = per_corner + 1
    if numbers.size != width.sum():
        return None
    first = np.cumsum(width) - width
    vt_raw = numbers[first + 1] if per_corner.min() >= 1 else None
    return counts.astype(np.int32), numbers[first], vt_raw


def _parse_obj_lines(data: bytes, source: str):
    """Line-by-line OBJ parse: slow, exact, and names the offending line."""
    pos: list[list[float]] = []
    colors: list[list[float]] | None = []
    uvs: list[list[float]] = []
    counts: list[int] = []
    vidx: list[int] = []
    vtidx: list[int] | None = []
    vt_lines: list[int] = []  # line of each face vertex's UV, to report a bad UV index
    pending, pending_no = "", 0
    for number, raw in enumerate(data.decode("utf-8", errors="replace").split("\n"), 1):
        raw = raw.rstrip("\r")
        if raw.rstrip().endswith("\\"):
            pending, pending_no = pending + raw.rstrip()[:-1] + " ", pending_no or number
            continue
        line = (pending + raw).split("#", 1)[0]
        number, pending, pending_no = pending_no or number, "", 0
        tokens = line.split()
        if not tokens:
            continue
        keyword, args = tokens[0], tokens[1:]
        if keyword == "v":
            values = _obj_floats(args)
            if values is None or len(values) not in (3, 4, 6):
                raise _obj_error(source, number, line, "is not a vertex (v x y z [w] or v x y z r g b)")
            pos.append(values[:3])
            if colors is not None and len(values) == 6:
                colors.append(values[3:])
            else:
                colors = None
        elif keyword == "vt":
            values = _obj_floats(args)
            if values is None or not 1 <= len(values) <= 3:
                raise _obj_error(source, number, line, "is not a texture coordinate (vt u [v [w]])")
            uvs.append((values + [0.0])[:2])
        elif keyword == "f":
            if len(args) < 3:
                raise _obj_error(source, number, line, "is not a face (it needs at least 3 vertices)")
            for corner in args:
                parts = corner.split("/")
                v = _obj_int(parts[0])
                vt = _obj_int(parts[1]) if len(parts) > 1 and parts[1] else None
                vn_ok = len(parts) < 3 or not parts[2] or _obj_int(parts[2]) is not None
                if len(parts) > 3 or v is None or (len(parts) > 1 and parts[1] and vt is None) or not vn_ok:
                    raise _obj_error(source, number, line, "is not a face")
                if v == 0 or vt == 0:
                    raise _obj_error(source, number, line, "uses index 0 (OBJ indices start at 1)")
                vidx.append(v - 1 if v > 0 else len(pos) + v)
                if vtidx is not None and vt is not None:
                    vtidx.append(vt - 1 if vt > 0 else len(uvs) + vt)
                    vt_lines.append(number)
                else:
                    vtidx = None
            counts.append(len(args))
        elif not keyword[0].isalpha():
            raise _obj_error(source, number, line, "is not an OBJ statement")
        # every other statement (vn, vp, o, g, s, usemtl, mtllib, l, p, ...) is ignored
    if vtidx is not None:
        for index, number in zip(vtidx, vt_lines):
            if not 0 <= index < len(uvs):
                reason = f"line {number}: UV index {index + 1} is out of range ({len(uvs)} vt lines)"
                raise _invalid(source, reason)
    return (
        np.array(pos, np.float64).reshape(-1, 3),
        np.array(colors, np.float64).reshape(-1, 3) if colors and len(colors) == len(pos) else None,
        np.array(uvs, np.float64).reshape(-1, 2),
        np.array(counts, np.int32),
        np.array(vidx, np.int64),
        np.array(vtidx, np.int64) if vtidx is not None and counts else None,
    )


def _obj_error(source: str, number: int, line: str, what: str) -> FormatError:
    return _invalid(source, f"line {number}: '{_snippet(line)}' {what}")


def _obj_floats(tokens: list[str]) -> list[float] | None:
    try:
        return [float(token) for token in tokens]
    except ValueError:
        return None


def _obj_int(token: str) -> int | None:
    try:
        return int(token)
    except ValueError:
        return None


# ---------------------------------------------------------------------------------------------
# OFF
#
# Our own parser: meshio's OFF reader refuses any face that is not a triangle ("Can only read
# triangular faces"), and its writer drops quads, so it cannot keep a quad garment.

_OFF_HEADER = re.compile(r"(ST)?(C)?(N)?(4)?(n)?OFF$")


def _read_off(source: str, prim: str | None) -> ClothMesh:
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
        values = _obj_floats(tokens)
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
        face = [_obj_int(token) for token in tokens]
        size = face[0]
        if size is None or size < 3 or len(face) < size + 1 or None in face[1 : size + 1]:
            raise _invalid(source, f"line {number}: '{_snippet(' '.join(tokens))}' is not a face")
        counts.append(size)
        indices.extend(face[1 : size + 1])
    indices = np.array(indices, np.int64)
    face_uv = _gather_uv(table[:, -2:], indices) if has_st else None
    return ClothMesh(table[:, :3], np.array(counts, np.int32), indices, face_uv, attrs, source)


# ---------------------------------------------------------------------------------------------
# PLY and STL through meshio
#
# meshio.read() prints the error and calls sys.exit(1) on a ReadError, so the per-format
# readers (meshio.ply.read, meshio.stl.read) are called instead: they raise.

_PLY_UV_NAMES = (("s", "t"), ("u", "v"), ("texture_u", "texture_v"))


def _read_ply(source: str, prim: str | None) -> ClothMesh:
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


def _meshio_polygons(cells) -> tuple[np.ndarray, np.ndarray]:
    """Triangle, quad and polygon cell blocks (in file order) -> counts, indices."""
    counts, indices = [np.zeros(0, np.int32)], [np.zeros(0, np.int64)]
    for block in cells:
        if block.type in ("triangle", "quad") or block.type.startswith("polygon"):
            data = np.asarray(block.data)
            counts.append(np.full(data.shape[0], data.shape[1], np.int32))
            indices.append(data.reshape(-1).astype(np.int64))
    return np.concatenate(counts), np.concatenate(indices)


def _read_stl(source: str, prim: str | None) -> ClothMesh:
    """STL keeps every triangle's corners apart; meshio merges exactly equal corners (in order
    of first appearance), which is the only way STL describes a connected surface."""
    import meshio

    size = os.path.getsize(source)
    with open(source, "rb") as file:
        head = file.read(84)
    if not head.lstrip().startswith(b"solid") and len(head) == 84:
        (n_triangles,) = struct.unpack("<I", head[80:84])
        if size != 84 + 50 * n_triangles:
            need = f"{n_triangles} triangles need {84 + 50 * n_triangles} bytes"
            raise _invalid(source, f"truncated binary STL: {need}, the file has {size}")
    with np.errstate(over="ignore"):  # meshio's size check overflows uint32 on ASCII files
        mesh = meshio.stl.read(source)
    counts, indices = _meshio_polygons(mesh.cells)
    return ClothMesh(np.asarray(mesh.points).reshape(-1, 3), counts, indices, source=source)


# ---------------------------------------------------------------------------------------------
# glTF / GLB through trimesh
#
# trimesh keeps TEXCOORD_0 only on primitives that have a material, and turns a COLOR_0
# without one into uint8 by a plain cast (wrong for the normalised uint16 Blender writes).
# So every primitive is pointed at one empty material before trimesh sees the file; then UVs
# arrive in `visual.uv` (flipped to a lower-left origin) and the raw COLOR_0 accessor in
# `visual.vertex_attributes["color"]`. Texture images are dropped on the way (not needed), and
# nodes are renamed to their index so that the pieces can be put back in file order.

_GLB_MAGIC, _GLB_JSON, _GLB_BIN = b"glTF", 0x4E4F534A, 0x004E4942


def _read_gltf(source: str, prim: str | None) -> ClothMesh:
    import trimesh

    gltf, binary = _gltf_split(Path(source).read_bytes(), source)
    if not isinstance(gltf, dict):
        raise _invalid(source, "the JSON is not a glTF object")
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
        return ClothMesh(np.zeros((0, 3)), np.zeros(0), np.zeros(0), source=source)
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
    )


# ---------------------------------------------------------------------------------------------
# USD through pxr


_USD_UV_TYPES = ("texCoord2f", "texCoord2d", "texCoord2h")
_USD_SCALAR_TYPES = ("float", "double", "half", "int", "uint", "int64", "uint64", "uchar", "bool")


def _read_usd(source: str, prim: str | None) -> ClothMesh:
    from pxr import Sdf, Usd, UsdGeom

    stage = Usd.Stage.Open(source)
    if stage is None:
        raise _invalid(source, "USD could not open the stage")
    found = [p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]
    if prim is not None:
        absolute = prim.startswith("/") and Sdf.Path.IsValidPathString(prim)
        chosen = stage.GetPrimAtPath(prim) if absolute else None
        if not chosen or not chosen.IsA(UsdGeom.Mesh):
            listing = ", ".join(str(p.GetPath()) for p in found[:8]) + (", ..." if len(found) > 8 else "")
            what = "is not a UsdGeom.Mesh" if chosen else "does not exist"
            raise MeshError(f"{source}: prim '{prim}' {what}; mesh prims in the file: {listing or 'none'}")
    elif found:
        chosen = found[0]
    else:
        raise MeshError(f"{source}: no UsdGeom.Mesh prim in the stage; export the garment as a polygon mesh")
    mesh = UsdGeom.Mesh(chosen)

    points = _usd_first_value(mesh.GetPointsAttr())
    counts = np.asarray(_usd_first_value(mesh.GetFaceVertexCountsAttr()) or [], np.int32)
    indices = np.asarray(_usd_first_value(mesh.GetFaceVertexIndicesAttr()) or [], np.int64)
    if points is None and counts.size:
        raise _invalid(source, f"mesh prim {chosen.GetPath()} has faces but no points")
    points = np.asarray(points if points is not None else np.zeros((0, 3)), np.float64).reshape(-1, 3)
    # EarliestTime: the value of a static transform, the first sample of an animated one (at
    # Default a transform with samples only reads as identity).
    matrix = np.array(mesh.ComputeLocalToWorldTransform(Usd.TimeCode.EarliestTime()), np.float64)
    points = points @ matrix[:3, :3] + matrix[3, :3]  # USD matrices act on row vectors

    n = len(points)
    attrs, uv_primvars = {}, []
    for primvar in UsdGeom.PrimvarsAPI(mesh).GetPrimvarsWithValues():
        name = primvar.GetPrimvarName()
        scalar = str(primvar.GetTypeName().scalarType)
        per_vertex = primvar.GetInterpolation() in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying)
        if scalar in _USD_UV_TYPES or (name == "st" and scalar in ("float2", "double2", "half2")):
            uv_primvars.append(primvar)
        elif name == "displayColor" and per_vertex:
            rgb = np.asarray(_usd_first_value(primvar.GetAttr(), primvar.ComputeFlattened), np.float32)
            if rgb.shape == (n, 3):
                attrs.update({"color_r": rgb[:, 0], "color_g": rgb[:, 1], "color_b": rgb[:, 2]})
        elif (
            per_vertex
            and scalar in _USD_SCALAR_TYPES
            and primvar.GetTypeName().isArray
            and primvar.GetElementSize() == 1
        ):
            values = _usd_first_value(primvar.GetAttr(), primvar.ComputeFlattened)
            if values is not None:
                attrs[name.rsplit(":", 1)[-1]] = np.asarray(values, np.float64).reshape(-1)
    face_uv = None
    uv_primvars.sort(key=lambda primvar: primvar.GetPrimvarName() != "st")  # `st`, else the first
    for primvar in uv_primvars[:1]:
        uv = _usd_first_value(primvar.GetAttr(), primvar.ComputeFlattened)
        uv = np.asarray(uv if uv is not None else [], np.float64).reshape(-1, 2)
        interpolation = primvar.GetInterpolation()
        if interpolation == UsdGeom.Tokens.faceVarying and len(uv) == len(indices):
            face_uv = uv
        elif interpolation in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying) and len(uv) == n:
            face_uv = _gather_uv(uv, indices)

    clockwise = mesh.GetOrientationAttr().Get() == UsdGeom.Tokens.leftHanded
    mirrored = np.linalg.det(matrix[:3, :3]) < 0
    if clockwise != mirrored and counts.size and counts.min() > 0 and counts.sum() == indices.size:
        order = _reverse_winding(counts, np.arange(indices.size))  # to counter-clockwise
        indices = indices[order]
        face_uv = None if face_uv is None else face_uv[order]
    return ClothMesh(
        vertex_pos=points,
        face_vertex_counts=counts,
        face_vertex_indices=indices,
        face_vertex_uv=face_uv,
        vertex_attrs=attrs,
        source=source,
        meters_per_unit=float(UsdGeom.GetStageMetersPerUnit(stage)),
        up_axis=str(UsdGeom.GetStageUpAxis(stage)),
    )


def _usd_first_value(attribute, get=None):
    """``get(time)`` (default: ``attribute.Get``) at the default time, else at the attribute's
    earliest time sample; None when neither has a value."""
    from pxr import Usd

    get = get or attribute.Get
    value = get(Usd.TimeCode.Default())
    if value is None:
        samples = attribute.GetTimeSamples()
        if samples:
            value = get(Usd.TimeCode(samples[0]))
    return value


# ---------------------------------------------------------------------------------------------
# registry: suffix -> reader(source, prim)

_READERS = {
    ".obj": _read_obj,
    ".ply": _read_ply,
    ".off": _read_off,
    ".stl": _read_stl,
    ".gltf": _read_gltf,
    ".glb": _read_gltf,
    ".usd": _read_usd,
    ".usda": _read_usd,
    ".usdc": _read_usd,
    ".usdz": _read_usd,
}
SUPPORTED_SUFFIXES: tuple[str, ...] = tuple(_READERS)
