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
from pathlib import Path

import numpy as np

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


def _read_csv(path: Path, where: str):
    try:
        with path.open(newline="") as handle:
            rows = list(csv.reader(handle))
    except FileNotFoundError:
        raise SceneError(f"{where}: track file {path.name} not found; check the 'file' path") from None
    if not rows:
        raise SceneError(f"{where}: {path.name} is empty; expected columns {CSV_COLUMNS}")
    header = [h.strip().lower() for h in rows[0]]
    time_column = "frame" if "frame" in header else "time" if "time" in header else None
    if time_column is None or not {"tx", "ty", "tz"} <= set(header):
        raise SceneError(f"{where}: {path.name} has columns {', '.join(header)}; expected {CSV_COLUMNS}")
    allowed = {"frame", "time", "tx", "ty", "tz", "qw", "qx", "qy", "qz", "sx", "sy", "sz", "s"}
    unknown = [h for h in header if h not in allowed]
    if unknown:
        raise SceneError(f"{where}: {path.name} has an unknown column '{unknown[0]}'; expected {CSV_COLUMNS}")
    try:
        data = np.array([[float(v) for v in row] for row in rows[1:] if row], np.float64)
    except ValueError as exc:
        raise SceneError(f"{where}: {path.name} has a value that is not a number ({exc}); fix the file") from None
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


def _read_npz(path: Path, where: str):
    try:
        data = np.load(path)
    except FileNotFoundError:
        raise SceneError(f"{where}: track file {path.name} not found; check the 'file' path") from None
    except (OSError, ValueError) as exc:
        raise SceneError(f"{where}: {path.name} is not a readable .npz file ({exc})") from None
    with data:
        names = set(data.files)
        time_column = "frame" if "frame" in names else "time" if "time" in names else None
        if time_column is None:
            raise SceneError(f"{where}: {path.name} has arrays {sorted(names)}; it needs 'frame' or 'time'")
        times = np.asarray(data[time_column], np.float64)
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
