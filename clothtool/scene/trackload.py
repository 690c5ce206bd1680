"""Tracks from scene tables: inline keys, or per-frame samples from a CSV or NPZ file.

Inline keys (``[track.NAME] keys = [...]``) each give ``time`` and any of ``translate``
(x, y, z), ``rotate`` (quaternion w, x, y, z), ``rotate_euler`` (degrees about X, Y, Z),
``scale`` (a number or x, y, z) or ``matrix`` (4x4, rows, translation in the last column),
which is decomposed. Channels a key leaves out hold the previous key's value.

CSV files need a header naming ``frame`` or ``time`` and then ``tx,ty,tz`` and optionally
``qw,qx,qy,qz`` and ``sx,sy,sz`` (or ``s``). NPZ files hold ``frame`` or ``time`` (k,) and any
of ``translate`` (k,3), ``rotate`` (k,4), ``scale`` (k,3), or ``matrix`` (k,4,4).
"""

from __future__ import annotations

import csv
import re
import stat
import zipfile
from pathlib import Path

import numpy as np
from numpy.lib import format as np_format

from clothtool.errors import SceneError
from clothtool.inputs import note_input
from clothtool.scene.tracks import INTERPOLATIONS, Track, decompose_matrix, euler_xyz_to_quat

TRACK_KEYS = ("interpolation", "time_unit", "keys", "file", "teleport")
KEY_KEYS = ("time", "translate", "rotate", "rotate_euler", "scale", "matrix")
TIME_UNITS = ("frames", "seconds")
CSV_COLUMNS = "frame|time, tx, ty, tz [, qw, qx, qy, qz] [, sx, sy, sz | s]"


def _vector(value, size: int, where: str) -> np.ndarray:
    try:
        array = np.asarray(value, np.float64)
    except (TypeError, ValueError):
        raise SceneError(f"{where}: expected {size} numbers, got {value!r}") from None
    if array.shape != (size,):
        raise SceneError(f"{where}: expected {size} numbers, got {value!r}")
    if not np.isfinite(array).all():
        raise SceneError(f"{where}: NaN or infinite value in {value!r}")
    return array


def _scale(value, where: str) -> np.ndarray:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return np.full(3, float(value))
    return _vector(value, 3, where)


def _keys_from_table(keys: list, where: str):
    if not isinstance(keys, list) or not keys:
        raise SceneError(f"{where}: key 'keys' must be a list of tables like {{ time = 1, translate = [0, 1, 0] }}")
    times, translations, rotations, scales = [], [], [], []
    translation, rotation, scale = np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]), np.ones(3)
    for i, key in enumerate(keys):
        at = f"{where}.keys[{i}]"
        if not isinstance(key, dict):
            raise SceneError(f"{at}: each key is a table like {{ time = 1, translate = [0, 1, 0] }}")
        unknown = set(key) - set(KEY_KEYS)
        if unknown:
            raise SceneError(f"{at}: unknown key '{sorted(unknown)[0]}'; allowed keys: {', '.join(KEY_KEYS)}")
        if "time" not in key:
            raise SceneError(f"{at}: missing 'time'")
        time = key["time"]
        if isinstance(time, bool) or not isinstance(time, (int, float)) or not np.isfinite(time):
            raise SceneError(f"{at}: key 'time' must be a number, got {time!r}")
        if "matrix" in key:
            if {"translate", "rotate", "rotate_euler", "scale"} & set(key):
                raise SceneError(f"{at}: give either 'matrix' or translate/rotate/scale, not both")
            translation, rotation, scale = decompose_matrix(key["matrix"], f"{at}: key 'matrix'")
        if "translate" in key:
            translation = _vector(key["translate"], 3, f"{at}: key 'translate'")
        if "rotate" in key and "rotate_euler" in key:
            raise SceneError(f"{at}: give either 'rotate' (quaternion) or 'rotate_euler', not both")
        if "rotate" in key:
            rotation = _vector(key["rotate"], 4, f"{at}: key 'rotate' (w, x, y, z)")
        if "rotate_euler" in key:
            rotation = euler_xyz_to_quat(_vector(key["rotate_euler"], 3, f"{at}: key 'rotate_euler'"))
        if "scale" in key:
            scale = _scale(key["scale"], f"{at}: key 'scale'")
        times.append(float(time))
        translations.append(translation)
        rotations.append(rotation)
        scales.append(scale)
    return np.asarray(times), np.asarray(translations), np.asarray(rotations), np.asarray(scales)


# Track files hold a few numbers per frame; anything bigger is not one.
MAX_TRACK_BYTES = 256 << 20


def _check_track_file(path: Path, where: str) -> None:
    """A regular file of at most MAX_TRACK_BYTES: checked before reading a byte."""
    try:
        info = path.stat()
    except FileNotFoundError:
        raise SceneError(f"{where}: track file {path.name} not found; check the 'file' path") from None
    except OSError as exc:
        raise SceneError(f"{where}: track file {path.name} cannot be read ({exc.strerror}); check the 'file' path") from None
    if not stat.S_ISREG(info.st_mode):
        raise SceneError(f"{where}: track file {path.name} is not a regular file; give a .csv or .npz file")
    if info.st_size > MAX_TRACK_BYTES:
        raise SceneError(f"{where}: track file {path.name} is {info.st_size:,} bytes, more than {MAX_TRACK_BYTES:,}; check the 'file' path")


def _read_csv(path: Path, where: str):
    _check_track_file(path, where)
    try:
        with path.open(newline="", encoding="utf-8") as handle:
            rows = list(csv.reader(handle))
    except UnicodeDecodeError:
        raise SceneError(f"{where}: {path.name} is not UTF-8 text (UTF-16 or binary?); save it as UTF-8 CSV") from None
    except csv.Error as exc:
        raise SceneError(f"{where}: {path.name} is not a readable CSV ({exc}); save it as plain UTF-8 CSV") from None
    if any("\0" in value for row in rows for value in row):
        raise SceneError(f"{where}: {path.name} holds NUL characters (binary data); save it as plain UTF-8 CSV")
    if not rows:
        raise SceneError(f"{where}: {path.name} is empty; expected columns {CSV_COLUMNS}")
    header = [h.strip().lower() for h in rows[0]]
    time_column = "frame" if "frame" in header else "time" if "time" in header else None
    if time_column is None or not {"tx", "ty", "tz"} <= set(header):
        raise SceneError(f"{where}: {path.name} has {_columns_shown(header)}; expected {CSV_COLUMNS}")
    allowed = {"frame", "time", "tx", "ty", "tz", "qw", "qx", "qy", "qz", "sx", "sy", "sz", "s"}
    unknown = [h for h in header if h not in allowed]
    if unknown:
        shown = f"'{unknown[0]}'" if _COLUMN_NAME.match(unknown[0]) else f"{header.index(unknown[0]) + 1}"
        raise SceneError(f"{where}: {path.name} has an unknown column {shown}; expected {CSV_COLUMNS}")
    data_rows = [row for row in rows[1:] if row]
    ragged = next((i for i, row in enumerate(data_rows) if len(row) != len(header)), None)
    if ragged is not None:
        raise SceneError(f"{where}: {path.name} row {ragged + 2} has {len(data_rows[ragged])} values, the header {len(header)}; fix the file")
    try:
        data = np.array([[float(v) for v in row] for row in data_rows], np.float64)
    except ValueError:
        # Name the place, not the text: the file may hold anything.
        line, column = next(
            (i + 2, j + 1) for i, row in enumerate(data_rows) for j, v in enumerate(row) if not _is_number(v)
        )
        raise SceneError(f"{where}: {path.name} row {line} column {column} is not a number; fix the file") from None
    if data.ndim != 2 or data.shape[0] == 0 or data.shape[1] != len(header):
        raise SceneError(f"{where}: {path.name} needs at least one row with {len(header)} values")
    column = {name: data[:, i] for i, name in enumerate(header)}
    k = data.shape[0]
    translations = np.stack([column["tx"], column["ty"], column["tz"]], axis=1)
    rotation_columns = ("qw", "qx", "qy", "qz")
    if any(c in column for c in rotation_columns):
        if not all(c in column for c in rotation_columns):
            raise SceneError(f"{where}: {path.name} needs all of qw, qx, qy, qz or none")
        rotations = np.stack([column[c] for c in rotation_columns], axis=1)
    else:
        rotations = np.tile([1.0, 0.0, 0.0, 0.0], (k, 1))
    if "s" in column:
        scales = np.repeat(column["s"][:, None], 3, axis=1)
    elif any(c in column for c in ("sx", "sy", "sz")):
        scales = np.stack([column[c] for c in ("sx", "sy", "sz")], axis=1)
    else:
        scales = np.ones((k, 3))
    return time_column, column[time_column], translations, rotations, scales


# Header cells quoted back in messages only when they look like column names (a file given
# by mistake, /etc/passwd say, must not have its first line echoed).
_COLUMN_NAME = re.compile(r"[a-z_][a-z0-9_]{0,31}\Z")


def _columns_shown(header: list[str]) -> str:
    if all(_COLUMN_NAME.match(h) for h in header):
        return "columns " + ", ".join(header)
    return "no header row of column names"


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _check_npz(path: Path, where: str) -> None:
    """Refuse members that are not plain number arrays (strings, pickled objects) or whose
    header claims more bytes than the member holds, before numpy allocates anything."""
    try:
        archive = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError):
        raise SceneError(f"{where}: {path.name} is not a readable .npz file (not a zip archive); save it with numpy.savez") from None
    with archive:
        for info in archive.infolist():
            name = info.filename.removesuffix(".npy")
            try:
                with archive.open(info) as member:
                    version = np_format.read_magic(member)
                    read_header = {(1, 0): np_format.read_array_header_1_0, (2, 0): np_format.read_array_header_2_0}.get(version)
                    if read_header is None:
                        raise ValueError(f"npy version {version}")
                    shape, _, dtype = read_header(member)
            except (ValueError, OSError, zipfile.BadZipFile, EOFError) as exc:
                raise SceneError(f"{where}: {path.name}: member '{name[:40]}' is not a numpy array ({type(exc).__name__}); save the file with numpy.savez") from None
            if dtype.kind not in "iuf" or dtype.fields is not None:
                raise SceneError(f"{where}: {path.name}: '{name[:40]}' holds {dtype} values; tracks need plain numbers (no strings or objects), save number arrays with numpy.savez")
            declared = int(np.prod(shape, dtype=object)) * dtype.itemsize
            if declared > info.file_size:
                raise SceneError(f"{where}: {path.name}: '{name[:40]}' claims shape {shape} ({declared:,} bytes) but holds {info.file_size:,}; the file is damaged, save it again with numpy.savez")


def _read_npz(path: Path, where: str):
    _check_track_file(path, where)
    _check_npz(path, where)
    try:
        data = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as exc:
        raise SceneError(f"{where}: {path.name} is not a readable .npz file ({type(exc).__name__}); save it with numpy.savez") from None
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise SceneError(f"{where}: {path.name} is a single .npy array, not an .npz archive; save it with numpy.savez")
    with data:
        names = set(data.files)
        time_column = "frame" if "frame" in names else "time" if "time" in names else None
        if time_column is None:
            raise SceneError(f"{where}: {path.name} has arrays {sorted(names)}; it needs 'frame' or 'time'")
        times = np.asarray(data[time_column], np.float64)
        if times.ndim != 1:
            raise SceneError(f"{where}: {path.name}: '{time_column}' has shape {times.shape}, expected (k,)")
        k = times.shape[0]
        if "matrix" in names:
            matrices = np.asarray(data["matrix"], np.float64)
            if matrices.shape != (k, 4, 4):
                raise SceneError(f"{where}: {path.name}: 'matrix' has shape {matrices.shape}, expected ({k}, 4, 4)")
            parts = [decompose_matrix(m, f"{where}: {path.name} matrix {i}") for i, m in enumerate(matrices)]
            return time_column, times, *(np.array(p) for p in zip(*parts))
        expected = {"translate": 3, "rotate": 4, "scale": 3}
        arrays = {}
        for name, width in expected.items():
            if name in names:
                arrays[name] = np.asarray(data[name], np.float64)
                if arrays[name].shape != (k, width):
                    raise SceneError(f"{where}: {path.name}: '{name}' has shape {arrays[name].shape}, expected ({k}, {width})")
        if "translate" not in arrays:
            raise SceneError(f"{where}: {path.name} needs a 'translate' (k,3) or 'matrix' (k,4,4) array")
    return (
        time_column,
        times,
        arrays["translate"],
        arrays.get("rotate", np.tile([1.0, 0.0, 0.0, 0.0], (k, 1))),
        arrays.get("scale", np.ones((k, 3))),
    )


def load_track(name: str, table: dict, fps: float, base_dir: Path) -> Track:
    """A Track from its ``[track.NAME]`` table; times become seconds."""
    where = f"track '{name}'"
    if not isinstance(table, dict):
        raise SceneError(f"{where}: must be a table with 'keys' or 'file'")
    unknown = set(table) - set(TRACK_KEYS)
    if unknown:
        raise SceneError(f"{where}: unknown key '{sorted(unknown)[0]}'; allowed keys: {', '.join(TRACK_KEYS)}")
    interpolation = table.get("interpolation", "linear")
    if interpolation not in INTERPOLATIONS:
        raise SceneError(f"{where}: key 'interpolation' = {interpolation!r}; use one of {', '.join(INTERPOLATIONS)}")
    if ("keys" in table) == ("file" in table):
        raise SceneError(f"{where}: give either 'keys' (inline keyframes) or 'file' (CSV/NPZ samples)")
    if "keys" in table:
        time_unit = table.get("time_unit", "frames")
        times, translations, rotations, scales = _keys_from_table(table["keys"], where)
    else:
        path = base_dir / str(table["file"])
        note_input(path)
        suffix = path.suffix.lower()
        if suffix == ".csv":
            column, times, translations, rotations, scales = _read_csv(path, where)
        elif suffix == ".npz":
            column, times, translations, rotations, scales = _read_npz(path, where)
        else:
            raise SceneError(f"{where}: track file {path.name} must be .csv or .npz")
        time_unit = "frames" if column == "frame" else "seconds"
        if "time_unit" in table and table["time_unit"] != time_unit:
            raise SceneError(f"{where}: key 'time_unit' says {table['time_unit']} but {path.name} has a '{column}' column")
    if time_unit not in TIME_UNITS:
        raise SceneError(f"{where}: key 'time_unit' = {time_unit!r}; use frames or seconds")
    seconds = times / fps if time_unit == "frames" else times
    teleport = table.get("teleport", [])
    if not isinstance(teleport, list) or not all(isinstance(f, int) and not isinstance(f, bool) for f in teleport):
        raise SceneError(f"{where}: key 'teleport' must be a list of frame numbers")
    return Track(name, seconds, translations, rotations, scales, interpolation, frozenset(teleport))
