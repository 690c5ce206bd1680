"""What every mesh reader shares: the FormatError it raises, token and colour conversions,
and the UV and winding helpers."""

from __future__ import annotations

import os
import re

import numpy as np

from clothtool.errors import FormatError


def _format_name(source: str) -> str:
    return os.path.splitext(source)[1].lstrip(".").upper() or "mesh"


def _invalid(source: str, reason: str) -> FormatError:
    return FormatError(
        f"{source}: not a valid {_format_name(source)} file ({reason}); re-export it from your DCC"
    )


def _first_line(exc: BaseException) -> str:
    """The first meaningful line of a library exception, without pxr's C++ location prefix."""
    try:
        text = str(exc)
    except UnicodeDecodeError:  # pxr's error quotes the file's undecodable bytes and fails to decode them
        return "it holds bytes that are not UTF-8 text"
    lines = [line.strip() for line in text.splitlines() if line.strip()]
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


def _parse_floats(tokens: list[str]) -> list[float] | None:
    try:
        return [float(token) for token in tokens]
    except ValueError:
        return None


def _parse_int(token: str) -> int | None:
    try:
        return int(token)
    except ValueError:
        return None


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


def _meshio_polygons(cells) -> tuple[np.ndarray, np.ndarray]:
    """Triangle, quad and polygon cell blocks (in file order) -> counts, indices."""
    counts, indices = [np.zeros(0, np.int32)], [np.zeros(0, np.int64)]
    for block in cells:
        if block.type in ("triangle", "quad") or block.type.startswith("polygon"):
            data = np.asarray(block.data)
            counts.append(np.full(data.shape[0], data.shape[1], np.int32))
            indices.append(data.reshape(-1).astype(np.int64))
    return np.concatenate(counts), np.concatenate(indices)
