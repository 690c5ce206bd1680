"""OBJ.

Our own parser: trimesh triangulates polygons on load, and meshio drops vertex colours and
per-corner (vt) UVs. A vectorised pass handles well-formed files; anything it is unsure
about goes to the line-by-line parser, which is the reference and names the bad line.
"""

from __future__ import annotations

import io
import re
import warnings
from pathlib import Path

import numpy as np

from clothtool.errors import FormatError
from clothtool.io.meshin._common import _invalid, _parse_floats, _parse_int, _snippet
from clothtool.mesh.clothmesh import ClothMesh

_OBJ_BLANKS = bytes.maketrans(b"\t\r", b"  ")
_OBJ_V, _OBJ_VT, _OBJ_F, _OBJ_SKIP, _OBJ_ODD = 1, 2, 3, 4, 5


def read(source: str, prim: str | None) -> ClothMesh:
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
            values = _parse_floats(args)
            if values is None or len(values) not in (3, 4, 6):
                raise _obj_error(source, number, line, "is not a vertex (v x y z [w] or v x y z r g b)")
            pos.append(values[:3])
            if colors is not None and len(values) == 6:
                colors.append(values[3:])
            else:
                colors = None
        elif keyword == "vt":
            values = _parse_floats(args)
            if values is None or not 1 <= len(values) <= 3:
                raise _obj_error(source, number, line, "is not a texture coordinate (vt u [v [w]])")
            uvs.append((values + [0.0])[:2])
        elif keyword == "f":
            if len(args) < 3:
                raise _obj_error(source, number, line, "is not a face (it needs at least 3 vertices)")
            for corner in args:
                parts = corner.split("/")
                v = _parse_int(parts[0])
                vt = _parse_int(parts[1]) if len(parts) > 1 and parts[1] else None
                vn_ok = len(parts) < 3 or not parts[2] or _parse_int(parts[2]) is not None
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


READERS = {".obj": read}
