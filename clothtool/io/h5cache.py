"""HDF5 caches (``.h5``, ``.hdf5``): one chunk per frame, flushed as it is written.

The layout is specified in ``formats/cache-h5/v1.md``. This module also holds what every
cache format shares (header/frame checks, the ``CacheReader`` base and the summary text);
``clothtool.io.usdcache`` imports them from here. h5py loads only when a file is opened.

    with H5CacheWriter(Path("shot.h5"), CacheOptions()) as writer:
        writer.write_header(header)
        for frame in frames:
            writer.write_frame(frame)
        writer.commit()

    with read_h5_cache("shot.h5") as cache:
        cache.points("skirt", cache.frames[-1])
"""

from __future__ import annotations

import contextlib
import json
import os
import re
from pathlib import Path

import numpy as np

from clothtool import __version__
from clothtool.errors import ClothtoolError, FormatError
from clothtool.io.atomic import check_output_path, temporary_sibling
from clothtool.io.cache import CacheHeader, CacheOptions, ClothTopology, ColliderInfo, FrameData, partial_path

FORMAT_NAME = "clothtool-cache"
FORMAT_VERSION = 1
HDF5_LIBVER = ("earliest", "v110")
ATTRIBUTES = frozenset({"velocities", "rest", "faces", "stats", "colliders"})
COLLIDER_KINDS = ("sphere", "capsule", "plane", "convex", "mesh")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_REQUIRED_PARAMS = {"sphere": ("radius",), "capsule": ("radius0", "radius1", "length"), "plane": (), "convex": ("planes",), "mesh": ()}


# ---------------------------------------------------------------------------------------------
# Shared by every cache format: checks of what the bake hands a writer.


def _check_name(path, what: str, name: str) -> None:
    if not isinstance(name, str) or not _NAME.match(name):
        raise ClothtoolError(f"{path}: {what} name {name!r} is not valid; use letters, digits and '_' (not first)")


def _check_unique(path, what: str, names: list[str]) -> None:
    for name in names:
        _check_name(path, what, name)
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise ClothtoolError(f"{path}: {what} name '{dupes[0]}' is used twice; give every {what} its own name")


def _check_cloth(path, cloth: ClothTopology) -> None:
    where = f"{path}: cloth '{cloth.name}'"
    n = cloth.rest_pos.shape[0] if cloth.rest_pos.ndim == 2 else 0
    if cloth.rest_pos.ndim != 2 or cloth.rest_pos.shape[1] != 3 or n == 0:
        raise ClothtoolError(f"{where}: rest_pos has shape {cloth.rest_pos.shape}; pass (n,3) positions with n >= 1")
    counts, indices = cloth.face_vertex_counts, cloth.face_vertex_indices
    if counts.ndim != 1 or indices.ndim != 1 or int(counts.sum()) != indices.shape[0] or (counts.size and counts.min() < 3):
        raise ClothtoolError(f"{where}: face_vertex_counts must be >= 3 and sum to len(face_vertex_indices); re-cook the fabric")
    if indices.size and (indices.min() < 0 or indices.max() >= n):
        raise ClothtoolError(f"{where}: face_vertex_indices reach outside 0..{n - 1}; re-cook the fabric")
    if cloth.face_vertex_uv is not None and cloth.face_vertex_uv.shape != (indices.shape[0], 2):
        raise ClothtoolError(f"{where}: face_vertex_uv has shape {cloth.face_vertex_uv.shape}, expected ({indices.shape[0]}, 2)")
    for key, values in cloth.vertex_primvars.items():
        _check_name(path, f"cloth '{cloth.name}' primvar", key)
        if np.shape(values) != (n,):
            raise ClothtoolError(f"{where}: primvar '{key}' has shape {np.shape(values)}, expected ({n},); paint one value per vertex")


def _check_collider(path, collider: ColliderInfo) -> None:
    where = f"{path}: collider '{collider.name}'"
    if collider.kind not in COLLIDER_KINDS:
        raise ClothtoolError(f"{where}: unknown kind '{collider.kind}'; use one of {', '.join(COLLIDER_KINDS)}")
    missing = [key for key in _REQUIRED_PARAMS[collider.kind] if key not in collider.params]
    if missing:
        raise ClothtoolError(f"{where}: {collider.kind} needs parameter '{missing[0]}'")
    if collider.kind == "convex" and np.shape(collider.params["planes"])[-1:] != (4,):
        raise ClothtoolError(f"{where}: planes must be an (m,4) array of (nx, ny, nz, d)")
    if collider.kind == "mesh" and any(
        a is None for a in (collider.face_vertex_counts, collider.face_vertex_indices, collider.rest_points)
    ):
        raise ClothtoolError(f"{where}: a mesh collider needs face_vertex_counts, face_vertex_indices and rest_points")


def validate_header(header: CacheHeader, path) -> None:
    """Refuse a header a reader could not reconstruct, with a message naming the element."""
    if not header.fps > 0:
        raise ClothtoolError(f"{path}: fps is {header.fps}; give a positive frame rate")
    if header.end_frame < header.start_frame:
        raise ClothtoolError(f"{path}: end frame {header.end_frame} is before start frame {header.start_frame}")
    if header.up_axis not in ("Y", "Z"):
        raise ClothtoolError(f"{path}: up axis '{header.up_axis}' is not supported; use Y or Z")
    if not header.meters_per_unit > 0:
        raise ClothtoolError(f"{path}: meters_per_unit is {header.meters_per_unit}; give a positive unit size")
    unknown = sorted(set(header.attributes) - ATTRIBUTES)
    if unknown:
        raise ClothtoolError(f"{path}: unknown cache attribute '{unknown[0]}'; use some of {', '.join(sorted(ATTRIBUTES))}")
    _check_unique(path, "cloth", [c.name for c in header.cloths])
    _check_unique(path, "collider", [c.name for c in header.colliders])
    _check_unique(path, "stats field", list(header.stats_fields))
    for cloth in header.cloths:
        _check_cloth(path, cloth)
    for collider in header.colliders:
        _check_collider(path, collider)
    for key, value in header.metadata.items():
        if not isinstance(key, str) or not key or not isinstance(value, str):
            raise ClothtoolError(f"{path}: metadata {key!r} must map a non-empty string to a string")


def check_frame(header: CacheHeader, frame: FrameData, expected: int, path) -> None:
    """Refuse a frame out of order or with arrays that do not match the header."""
    if frame.frame != expected:
        raise ClothtoolError(f"{path}: got frame {frame.frame}, expected {expected}; write frames in order without gaps")
    if frame.frame > header.end_frame:
        raise ClothtoolError(f"{path}: frame {frame.frame} is after the header's end frame {header.end_frame}")
    _check_per_cloth(header, frame.frame, "points", frame.points, path)
    if "velocities" in header.attributes:
        _check_per_cloth(header, frame.frame, "velocities", frame.velocities, path)
    if "stats" in header.attributes and header.stats_fields:
        if frame.stats is None or len(frame.stats) != len(header.cloths):
            raise ClothtoolError(f"{path}: frame {frame.frame} has no stats per cloth; pass one dict per cloth")
        for cloth, stats in zip(header.cloths, frame.stats):
            missing = [f for f in header.stats_fields if f not in stats]
            if missing:
                raise ClothtoolError(f"{path}: cloth '{cloth.name}' frame {frame.frame} lacks stat '{missing[0]}'")
    if writes_colliders(header):
        xforms = frame.collider_xforms
        if xforms is None or len(xforms) != len(header.colliders) or any(np.shape(m) != (4, 4) for m in xforms):
            raise ClothtoolError(f"{path}: frame {frame.frame} needs one (4,4) transform per collider in header order")


def _check_per_cloth(header: CacheHeader, number: int, what: str, arrays, path) -> None:
    if arrays is None or len(arrays) != len(header.cloths):
        raise ClothtoolError(f"{path}: frame {number} needs {what} for each of the {len(header.cloths)} cloths")
    for cloth, array in zip(header.cloths, arrays):
        if np.shape(array) != (cloth.particle_count, 3):
            raise ClothtoolError(
                f"{path}: cloth '{cloth.name}' frame {number} {what} have shape {np.shape(array)}, "
                f"expected ({cloth.particle_count}, 3); pass arrays in header order"
            )


def writes_colliders(header: CacheHeader) -> bool:
    return "colliders" in header.attributes and bool(header.colliders)


def deformed_collider_points(header: CacheHeader, frame: FrameData, deforming: set[int] | None, path) -> dict[int, np.ndarray]:
    """Per mesh collider index, the frame's deformed points (f32 (m,3), local frame).

    A mesh collider deforms when the first frame gives its points (``deforming`` is None on
    the first frame); a static one costs nothing per frame. A deforming collider must give
    its points on every later frame.
    """
    given = frame.collider_points or (None,) * len(header.colliders)
    moved = {}
    for i, collider in enumerate(header.colliders):
        points = given[i] if i < len(given) else None
        if collider.kind != "mesh" or (points is None and (deforming is None or i not in deforming)):
            continue
        if points is None or np.shape(points) != np.shape(collider.rest_points):
            raise ClothtoolError(
                f"{path}: collider '{collider.name}' frame {frame.frame} needs deformed points of shape "
                f"{np.shape(collider.rest_points)} (its first frame had them); pass them every frame"
            )
        moved[i] = as_points(points)
    return moved


def as_points(array) -> np.ndarray:
    return np.ascontiguousarray(array, dtype=np.float32)


def points_extent(points: np.ndarray) -> np.ndarray:
    """f32 (2,3): the bounding box (min row, max row) of (n,3) points."""
    # numpy reduces an (n,3) array along axis 0 some 25x slower than three contiguous rows.
    columns = np.ascontiguousarray(points.T)
    return np.stack([columns.min(axis=1), columns.max(axis=1)]).astype(np.float32)


def scalar_params_json(params: dict) -> str:
    """Canonical JSON (sorted keys) of a collider's scalar parameters; arrays are left out."""
    scalars = {k: float(v) if isinstance(v, (int, float, np.number)) else v for k, v in params.items() if np.ndim(v) == 0}
    return json.dumps(scalars, sort_keys=True)


# ---------------------------------------------------------------------------------------------
# Shared by every cache reader.


class CacheReader:
    """The API of every cache reader (``read_h5_cache``, ``read_usd_cache``).

    A context manager (``close()`` on exit) with:
        header: CacheHeader with cloth topologies and colliders reconstructed; ``end_frame``
            is the last frame actually written (a partial file ends early).
        frames: list of the frame numbers written, in order.
        points(cloth, frame) -> f32 (n,3); velocities(cloth, frame) -> f32 (n,3) or None;
        extent(cloth, frame) -> f32 (2,3) (min row, max row);
        stats(cloth) -> {field: f64 (frames,)} or None;
        collider_xform(collider, frame) -> f64 (4,4) (row vectors: translation in the last row);
        summary() -> JSON-ready dict (see ``format_cache_summary``).
    Subclasses set ``path``, ``header``, ``frames``, ``format_label``, ``requested_end_frame``
    and implement the accessors plus ``_extents(cloth) -> f32 (frames,2,3)``.
    """

    path: Path
    header: CacheHeader
    frames: list[int]
    format_label: str
    requested_end_frame: int

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close()

    def close(self) -> None:  # pragma: no cover - overridden
        pass

    def _cloth_index(self, name: str) -> int:
        names = [c.name for c in self.header.cloths]
        if name not in names:
            raise ClothtoolError(f"{self.path}: no cloth named '{name}'; the cache has {', '.join(names) or 'none'}")
        return names.index(name)

    def _collider_index(self, name: str) -> int:
        names = [c.name for c in self.header.colliders]
        if name not in names:
            raise ClothtoolError(f"{self.path}: no collider named '{name}'; the cache has {', '.join(names) or 'none'}")
        return names.index(name)

    def _frame_index(self, frame: int) -> int:
        index = int(frame) - self.header.start_frame
        if not 0 <= index < len(self.frames):
            span = f"{self.frames[0]}-{self.frames[-1]}" if self.frames else "none"
            raise ClothtoolError(f"{self.path}: frame {frame} is not in the cache (frames written: {span})")
        return index

    def summary(self) -> dict:
        """Format, frame range, units, cloths with bounds over all frames, colliders, size."""
        header = self.header
        cloths = []
        for cloth in header.cloths:
            extents = self._extents(cloth.name)
            box = None
            if extents.shape[0]:
                box = {"min": [float(v) for v in extents[:, 0].min(axis=0)], "max": [float(v) for v in extents[:, 1].max(axis=0)]}
            cloths.append(
                {
                    "name": cloth.name,
                    "points": cloth.particle_count,
                    "faces": int(cloth.face_vertex_counts.shape[0]),
                    "has_uv": cloth.face_vertex_uv is not None,
                    "primvars": sorted(cloth.vertex_primvars),
                    "bounding_box": box,
                }
            )
        return {
            "kind": "cache",
            "format": FORMAT_NAME,
            "container": self.format_label,
            "format_version": FORMAT_VERSION,
            "fps": float(header.fps),
            "start_frame": header.start_frame,
            "end_frame": header.end_frame,
            "requested_end_frame": self.requested_end_frame,
            "frames_written": len(self.frames),
            "complete": bool(self.frames) and self.frames[-1] == self.requested_end_frame,
            "meters_per_unit": float(header.meters_per_unit),
            "up_axis": header.up_axis,
            "cloths": cloths,
            "colliders": [{"name": c.name, "kind": c.kind} for c in header.colliders],
            "attributes": sorted(header.attributes | {"points"}),
            "stats_fields": list(header.stats_fields),
            "metadata": dict(sorted(header.metadata.items())),
            "file_size_bytes": self.path.stat().st_size,
        }


def format_cache_summary(summary: dict, name: str) -> str:
    """A few lines for people: what ``clothtool inspect CACHE`` prints."""
    written = summary["frames_written"]
    total = summary["requested_end_frame"] - summary["start_frame"] + 1
    state = "complete" if summary["complete"] else f"partial: {written} of {total} frames"
    lines = [
        f"cache {name} ({summary['container']}, {summary['format']} v{summary['format_version']}, {state})",
        f"  frames     {summary['start_frame']}-{summary['end_frame']} at {summary['fps']:g} fps ({written} written)",
        f"  units      {summary['meters_per_unit']:g} m per unit, up axis {summary['up_axis']}",
    ]
    for cloth in summary["cloths"]:
        line = f"  cloth      {cloth['name']}: {cloth['points']} points, {cloth['faces']} faces, uv: {'yes' if cloth['has_uv'] else 'no'}"
        box = cloth["bounding_box"]
        if box:
            line += "; bounds (" + ", ".join(f"{v:.4g}" for v in box["min"]) + ") - (" + ", ".join(f"{v:.4g}" for v in box["max"]) + ")"
        lines.append(line)
    if summary["colliders"]:
        lines.append("  colliders  " + ", ".join(f"{c['name']} ({c['kind']})" for c in summary["colliders"]))
    lines.append("  attributes " + ", ".join(summary["attributes"]))
    lines.append(f"  size       {summary['file_size_bytes'] / 2**20:.2f} MiB")
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# The HDF5 writer.

_COMPRESSION = {
    "gzip": dict(compression="gzip", compression_opts=1, shuffle=True),
    "lzf": dict(compression="lzf", shuffle=True),
    "none": {},
}
# Small per-frame series (extent, stats, transforms): chunks of this many frames, uncompressed.
_SERIES_CHUNK = 64


class H5CacheWriter:
    """Stream frames into an HDF5 cache; see the module docstring and formats/cache-h5/v1.md."""

    def __init__(self, path: Path, options: CacheOptions = CacheOptions()):
        self.path = check_output_path(path)
        if options.compression not in _COMPRESSION:
            raise ClothtoolError(f"{path}: unknown compression '{options.compression}'; use {', '.join(_COMPRESSION)}")
        self._filters = _COMPRESSION[options.compression]
        self._tmp = temporary_sibling(self.path)
        self._file = None
        self._header: CacheHeader | None = None
        self._committed = False
        self._deforming: set[int] = set()
        self.frames_written = 0

    def __enter__(self) -> "H5CacheWriter":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if self._committed:
            return
        self._close()
        if self.frames_written:
            os.replace(self._tmp, partial_path(self.path))
        with contextlib.suppress(FileNotFoundError):
            self._tmp.unlink()

    def write_header(self, header: CacheHeader) -> None:
        import h5py

        if self._header is not None:
            raise ClothtoolError(f"{self.path}: write_header called twice; write the header once")
        validate_header(header, self.path)
        self._header = header
        try:
            self._file = f = h5py.File(self._tmp, "w", libver=HDF5_LIBVER)
        except OSError as exc:
            raise ClothtoolError(f"{self.path}: cannot create the HDF5 file ({_first_line(exc)}); check the directory is writable") from None
        _write_root_attrs(f, header)
        for cloth in header.cloths:
            self._create_cloth(f.create_group(f"cloth/{cloth.name}"), cloth, header)
        if writes_colliders(header):
            for collider in header.colliders:
                self._create_collider(f.create_group(f"collider/{collider.name}"), collider)
        f.flush()

    def _series(self, group, name: str, shape: tuple, dtype, per_frame_chunk: bool = False):
        # Datasets grow one frame at a time, so a partial file holds exactly the frames written.
        chunks = (1, *shape) if per_frame_chunk else (_SERIES_CHUNK, *shape)
        filters = self._filters if per_frame_chunk else {}
        return group.create_dataset(name, shape=(0, *shape), maxshape=(None, *shape), dtype=dtype, chunks=chunks, **filters)

    def _create_cloth(self, g, cloth: ClothTopology, header: CacheHeader) -> None:
        n = cloth.particle_count
        self._series(g, "P", (n, 3), np.float32, per_frame_chunk=True)
        if "velocities" in header.attributes:
            self._series(g, "v", (n, 3), np.float32, per_frame_chunk=True)
        self._series(g, "extent", (2, 3), np.float32)
        if "rest" in header.attributes:
            g.create_dataset("rest", data=as_points(cloth.rest_pos))
        # Topology is always written: the DCCs need it to rebuild the mesh.
        g.create_dataset("face_vertex_counts", data=np.asarray(cloth.face_vertex_counts, np.int32))
        g.create_dataset("face_vertex_indices", data=np.asarray(cloth.face_vertex_indices, np.int32))
        if cloth.face_vertex_uv is not None:
            g.create_dataset("face_vertex_uv", data=np.asarray(cloth.face_vertex_uv, np.float32))
        if cloth.vertex_primvars:
            primvars = g.create_group("primvars")
            for key in sorted(cloth.vertex_primvars):
                primvars.create_dataset(key, data=np.asarray(cloth.vertex_primvars[key], np.float32))
        if "stats" in header.attributes and header.stats_fields:
            stats = g.create_group("stats")
            for field in header.stats_fields:
                self._series(stats, field, (), np.float64)

    def _create_collider(self, g, collider: ColliderInfo) -> None:
        g.attrs["kind"] = collider.kind
        g.attrs["params"] = scalar_params_json(collider.params)
        self._series(g, "xform", (4, 4), np.float64)
        for key in sorted(collider.params):
            if np.ndim(collider.params[key]):  # convex "planes": (m,4)
                g.create_dataset(key, data=np.asarray(collider.params[key], np.float64))
        if collider.kind == "mesh":
            g.create_dataset("face_vertex_counts", data=np.asarray(collider.face_vertex_counts, np.int32))
            g.create_dataset("face_vertex_indices", data=np.asarray(collider.face_vertex_indices, np.int32))
            g.create_dataset("rest_points", data=as_points(collider.rest_points))

    def write_frame(self, frame: FrameData) -> None:
        header = self._header
        if header is None:
            raise ClothtoolError(f"{self.path}: write_frame called before write_header")
        check_frame(header, frame, header.start_frame + self.frames_written, self.path)
        moved = {}
        if writes_colliders(header):  # checked before anything of the frame is written
            moved = deformed_collider_points(header, frame, self._deforming if self.frames_written else None, self.path)
        try:
            self._write_frame(frame, moved)
        except OSError as exc:
            raise ClothtoolError(f"{self.path}: cannot write frame {frame.frame} ({_first_line(exc)}); check free disk space") from None
        self._deforming = set(moved)
        self.frames_written += 1

    def _write_frame(self, frame: FrameData, moved: dict[int, np.ndarray]) -> None:
        header, f, k = self._header, self._file, self.frames_written
        for i, cloth in enumerate(header.cloths):
            g = f["cloth"][cloth.name]
            points = as_points(frame.points[i])
            _append(g["P"], k, points)
            _append(g["extent"], k, points_extent(points))
            if "v" in g:
                _append(g["v"], k, as_points(frame.velocities[i]))
            if "stats" in g:
                for field in header.stats_fields:
                    _append(g["stats"][field], k, float(frame.stats[i][field]))
        if writes_colliders(header):
            self._write_colliders(frame, k, moved)
        f.attrs["frame_count"] = k + 1
        # Flushing every frame keeps memory flat and leaves a readable file after a crash.
        f.flush()

    def _write_colliders(self, frame: FrameData, k: int, moved: dict[int, np.ndarray]) -> None:
        header = self._header
        for i, collider in enumerate(header.colliders):
            g = self._file["collider"][collider.name]
            _append(g["xform"], k, np.asarray(frame.collider_xforms[i], np.float64))
            if i in moved:
                if k == 0:  # created on the first frame: only deforming meshes get one
                    self._series(g, "P", moved[i].shape, np.float32, per_frame_chunk=True)
                _append(g["P"], k, moved[i])

    def commit(self) -> None:
        if self._header is None:
            raise ClothtoolError(f"{self.path}: commit called before write_header")
        self._close()
        os.replace(self._tmp, self.path)
        self._committed = True

    def _close(self) -> None:
        if self._file is None:
            return
        with contextlib.suppress(Exception):
            _trim(self._file, self.frames_written)
        self._file.close()
        self._file = None


def _append(dataset, k: int, value) -> None:
    dataset.resize(k + 1, axis=0)
    dataset[k] = value


def _trim(f, frames: int) -> None:
    """Shrink every per-frame dataset to ``frames`` (after a failure in the middle of a frame)."""

    def visit(name, obj):
        if hasattr(obj, "maxshape") and obj.maxshape and obj.maxshape[0] is None and obj.shape[0] > frames:
            obj.resize(frames, axis=0)

    f.visititems(visit)


def _write_root_attrs(f, header: CacheHeader) -> None:
    f.attrs["format"] = FORMAT_NAME
    f.attrs["format_version"] = FORMAT_VERSION
    f.attrs["generator"] = f"clothtool {__version__}"
    f.attrs["fps"] = float(header.fps)
    f.attrs["start_frame"] = int(header.start_frame)
    f.attrs["end_frame"] = int(header.end_frame)
    f.attrs["frame_count"] = 0
    f.attrs["meters_per_unit"] = float(header.meters_per_unit)
    f.attrs["up_axis"] = header.up_axis
    # Group iteration in HDF5 is alphabetical: keep the bake order explicitly.
    f.attrs["cloths"] = json.dumps([c.name for c in header.cloths])
    f.attrs["colliders"] = json.dumps([c.name for c in header.colliders] if writes_colliders(header) else [])
    f.attrs["attributes"] = json.dumps(sorted(header.attributes | {"faces"}))
    f.attrs["stats_fields"] = json.dumps(list(header.stats_fields) if "stats" in header.attributes else [])
    for key in sorted(header.metadata):
        f.attrs[f"meta:{key}"] = header.metadata[key]


# ---------------------------------------------------------------------------------------------
# The HDF5 reader.


def read_h5_cache(path: str | os.PathLike) -> "H5CacheReader":
    """Open an HDF5 cache; raise FormatError if it is missing, truncated or not a cache."""
    return H5CacheReader(Path(path))


def _fail(path, message: str):
    raise FormatError(f"{path}: {message}")


class H5CacheReader(CacheReader):
    """Reads a cache written by H5CacheWriter (API in ``CacheReader``)."""

    format_label = "hdf5"

    def __init__(self, path: Path):
        import h5py

        self.path = path
        if not path.is_file():
            _fail(path, "cache file not found; check the path or bake it with 'clothtool bake'")
        try:
            self._file = h5py.File(path, "r")
        except OSError as exc:
            _fail(path, f"cannot be read as HDF5 ({_first_line(exc)}); the file is truncated or damaged, bake it again")
        try:
            self._load()
        except FormatError:
            self.close()
            raise
        except (OSError, KeyError, ValueError, TypeError) as exc:
            self.close()
            _fail(path, f"cannot be read as a cache ({_first_line(exc)}); the file is truncated or damaged, bake it again")

    def close(self) -> None:
        if getattr(self, "_file", None) is not None:
            self._file.close()
            self._file = None

    def _load(self) -> None:
        f, path = self._file, self.path
        fmt = f.attrs.get("format")
        if fmt != FORMAT_NAME:
            hint = "it is a fabric; give the cache written by 'clothtool bake'" if fmt == "clothtool-fabric" else "bake one with 'clothtool bake'"
            _fail(path, f"not a clothtool cache (format attribute is {fmt!r}); {hint}")
        version = int(f.attrs.get("format_version", -1))
        if version != FORMAT_VERSION:
            _fail(path, f"cache format version {version} is not supported (this clothtool reads {FORMAT_VERSION}); bake it again")
        names = json.loads(f.attrs["cloths"])
        for name in names:
            if f"cloth/{name}/P" not in f:
                _fail(path, f"cloth '{name}' is missing; the file is truncated or damaged, bake it again")
        # A crash between writing a frame and updating frame_count leaves extra rows: ignore them.
        count = int(f.attrs["frame_count"])
        count = min([count] + [f[f"cloth/{name}/P"].shape[0] for name in names])
        start = int(f.attrs["start_frame"])
        self.frames = list(range(start, start + count))
        self.requested_end_frame = int(f.attrs["end_frame"])
        present = set(json.loads(f.attrs["attributes"]))
        self.header = CacheHeader(
            fps=float(f.attrs["fps"]),
            start_frame=start,
            end_frame=start + count - 1,
            meters_per_unit=float(f.attrs["meters_per_unit"]),
            up_axis=str(f.attrs["up_axis"]),
            cloths=tuple(self._cloth_topology(name, f[f"cloth/{name}"]) for name in names),
            colliders=tuple(self._collider_info(name, f[f"collider/{name}"]) for name in json.loads(f.attrs["colliders"])),
            attributes=frozenset(present),
            stats_fields=tuple(json.loads(f.attrs["stats_fields"])),
            metadata={k[5:]: str(v) for k, v in sorted(f.attrs.items()) if k.startswith("meta:")},
        )

    def _cloth_topology(self, name: str, g) -> ClothTopology:
        n = g["P"].shape[1]
        if "rest" in g:
            rest = g["rest"][()]
        elif self.frames:
            rest = g["P"][0]  # no rest pose written: the first frame stands in for it
        else:
            rest = np.zeros((n, 3), np.float32)
        primvars = {key: g["primvars"][key][()] for key in g["primvars"]} if "primvars" in g else {}
        return ClothTopology(
            name=name,
            rest_pos=np.asarray(rest, np.float32),
            face_vertex_counts=g["face_vertex_counts"][()],
            face_vertex_indices=g["face_vertex_indices"][()],
            face_vertex_uv=g["face_vertex_uv"][()] if "face_vertex_uv" in g else None,
            vertex_primvars=primvars,
        )

    def _collider_info(self, name: str, g) -> ColliderInfo:
        params = json.loads(g.attrs["params"])
        for key in g:
            if key not in ("xform", "P", "face_vertex_counts", "face_vertex_indices", "rest_points"):
                params[key] = g[key][()]
        mesh = str(g.attrs["kind"]) == "mesh"
        return ColliderInfo(
            name=name,
            kind=str(g.attrs["kind"]),
            params=params,
            face_vertex_counts=g["face_vertex_counts"][()] if mesh else None,
            face_vertex_indices=g["face_vertex_indices"][()] if mesh else None,
            rest_points=g["rest_points"][()] if mesh else None,
        )

    def _cloth_group(self, name: str):
        self._cloth_index(name)
        return self._file["cloth"][name]

    def points(self, cloth: str, frame: int) -> np.ndarray:
        return self._row(self._cloth_group(cloth)["P"], frame, np.float32)

    def velocities(self, cloth: str, frame: int) -> np.ndarray | None:
        g = self._cloth_group(cloth)
        return self._row(g["v"], frame, np.float32) if "v" in g else None

    def extent(self, cloth: str, frame: int) -> np.ndarray:
        return self._row(self._cloth_group(cloth)["extent"], frame, np.float32)

    def stats(self, cloth: str) -> dict[str, np.ndarray] | None:
        g = self._cloth_group(cloth)
        if "stats" not in g:
            return None
        count = len(self.frames)
        return {field: np.asarray(g["stats"][field][:count], np.float64) for field in self.header.stats_fields}

    def collider_xform(self, collider: str, frame: int) -> np.ndarray:
        self._collider_index(collider)
        return self._row(self._file["collider"][collider]["xform"], frame, np.float64)

    def collider_points(self, collider: str, frame: int) -> np.ndarray | None:
        self._collider_index(collider)
        g = self._file["collider"][collider]
        return self._row(g["P"], frame, np.float32) if "P" in g else None

    def _row(self, dataset, frame: int, dtype) -> np.ndarray:
        index = self._frame_index(frame)
        try:
            return np.asarray(dataset[index], dtype)
        except (OSError, ValueError) as exc:
            _fail(self.path, f"frame {frame} cannot be read ({_first_line(exc)}); the file is damaged, bake it again")

    def _extents(self, cloth: str) -> np.ndarray:
        return np.asarray(self._cloth_group(cloth)["extent"][: len(self.frames)], np.float32)


def _first_line(exc: Exception) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
