"""The cache-writer protocol shared by every cache format, and the registry by suffix.

A bake streams frames into a writer:

    with open_cache_writer(path, options) as writer:
        writer.write_header(header)
        for frame in frames:
            writer.write_frame(frame_data)
        writer.commit()            # success: the temporary file becomes `path`

Leaving the ``with`` block without ``commit()`` (an exception, an unstable bake) keeps the
frames written so far under ``partial_path(path)`` (when there is at least one frame) and
never leaves a file under ``path``. Memory does not grow with the frame count: writers
flush each frame (HDF5) or save every few frames (USD).
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Protocol

import numpy as np

from clothtool.collision.colliders import ColliderInfo  # the scene builds it, the writers store it
from clothtool.errors import FormatError, UsageError


@dataclasses.dataclass(frozen=True)
class ClothTopology:
    """What a cache needs to know about one cloth before the first frame.

    Attributes:
        name: cloth instance name (a valid USD prim / HDF5 group name: [A-Za-z_][A-Za-z0-9_]*).
        rest_pos: f32 (n,3) rest positions in scene units (after the instance transform).
        face_vertex_counts, face_vertex_indices: i32 render topology (quads kept).
        face_vertex_uv: f32 (fv,2) or None.
        vertex_primvars: name -> f32 (n,) constant per-vertex extras (e.g. "pin", "max_distance")
            written once; USD writes them as ``primvars:clothtool:<name>``.
    """

    name: str
    rest_pos: np.ndarray
    face_vertex_counts: np.ndarray
    face_vertex_indices: np.ndarray
    face_vertex_uv: np.ndarray | None = None
    vertex_primvars: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)

    @property
    def particle_count(self) -> int:
        return int(self.rest_pos.shape[0])


@dataclasses.dataclass(frozen=True)
class CacheHeader:
    """Scene-level metadata, written once before the first frame.

    Attributes:
        fps: frames per second (> 0).
        start_frame, end_frame: inclusive frame range that will be written.
        meters_per_unit: scene unit in metres.
        up_axis: "Y" or "Z".
        cloths: topology of each cloth, in bake order.
        colliders: colliders to write as animated transforms (may be empty).
        attributes: optional per-frame data to write: a subset of
            {"velocities", "rest", "faces", "stats", "colliders"}. Points are always written.
        stats_fields: names of the per-frame scalar stats (when "stats" is requested).
        metadata: extra string metadata (scene name, solver preset, ...) stored as-is;
            must contain no absolute paths, host names or timestamps.
    """

    fps: float
    start_frame: int
    end_frame: int
    meters_per_unit: float
    up_axis: str
    cloths: tuple[ClothTopology, ...]
    colliders: tuple[ColliderInfo, ...] = ()
    attributes: frozenset[str] = frozenset({"velocities"})
    stats_fields: tuple[str, ...] = ()
    metadata: dict[str, str] = dataclasses.field(default_factory=dict)

    @property
    def frame_count(self) -> int:
        return self.end_frame - self.start_frame + 1


@dataclasses.dataclass(frozen=True)
class FrameData:
    """One frame of a bake.

    Attributes:
        frame: frame number (start_frame, start_frame + 1, ... in order).
        points: per cloth (header order) f32 (n,3) positions in scene units.
        velocities: per cloth f32 (n,3) in scene units per second, or None if not written.
        stats: per cloth {field: float} for the header's stats_fields, or None.
        collider_xforms: per collider (header order) f64 (4,4) world matrix (row-vector
            convention as in USD: translation in the last row), or None.
        collider_points: per collider f32 (m,3) deformed points for mesh colliders (None for
            the others, or None overall).
    """

    frame: int
    points: tuple[np.ndarray, ...]
    velocities: tuple[np.ndarray, ...] | None = None
    stats: tuple[dict[str, float], ...] | None = None
    collider_xforms: tuple[np.ndarray, ...] | None = None
    collider_points: tuple[np.ndarray | None, ...] | None = None


class CacheWriter(Protocol):
    """A writer may also set ``discards_frames = True`` and have ``skip_frame(frame)``: the
    bake then calls that instead of building each frame's data (clothtool.io.null)."""

    path: Path

    def __enter__(self) -> "CacheWriter": ...

    def __exit__(self, exc_type, exc, tb) -> None: ...

    def write_header(self, header: CacheHeader) -> None: ...

    def write_frame(self, frame: FrameData) -> None: ...

    def commit(self) -> None: ...


@dataclasses.dataclass(frozen=True)
class CacheOptions:
    """Writer options (each has a bake command-line flag).

    compression: HDF5 "gzip" (shuffle + gzip level 1), "lzf" or "none".
    save_every: USD: save the layer every this many frames so memory stays flat.
    """

    compression: str = "gzip"
    save_every: int = 10


def partial_path(path: str | os.PathLike) -> Path:
    """Where a failed bake keeps its frames: ``shot.usdc`` -> ``shot.partial.usdc``."""
    path = Path(path)
    return path.with_name(f"{path.stem}.partial{path.suffix}")


NULL_OUTPUTS = ("null", os.devnull)

# suffix -> (module, writer class, reader function); imported only when used
_WRITERS = {
    ".h5": ("clothtool.io.h5cache", "H5CacheWriter", "read_h5_cache"),
    ".hdf5": ("clothtool.io.h5cache", "H5CacheWriter", "read_h5_cache"),
    ".usd": ("clothtool.io.usdcache", "UsdCacheWriter", "read_usd_cache"),
    ".usda": ("clothtool.io.usdcache", "UsdCacheWriter", "read_usd_cache"),
    ".usdc": ("clothtool.io.usdcache", "UsdCacheWriter", "read_usd_cache"),
}


def supported_suffixes() -> tuple[str, ...]:
    return tuple(_WRITERS)


def _entry(path: str | os.PathLike):
    suffix = Path(path).suffix.lower()
    if suffix not in _WRITERS:
        raise FormatError(
            f"{path}: unknown cache format '{suffix}'; use one of {', '.join(_WRITERS)} (or 'null' to discard frames)"
        )
    return _WRITERS[suffix]


def check_cache_output_name(path: str | os.PathLike) -> None:
    """Refuse (as a usage error) an output this bake cannot write: an unknown suffix, a
    missing directory, a directory."""
    from clothtool.io.atomic import check_output_path

    if str(path) in NULL_OUTPUTS:
        return
    suffix = Path(path).suffix.lower()
    if suffix not in _WRITERS:
        raise UsageError(
            f"{path}: a cache cannot be written as '{suffix or '(no suffix)'}'; "
            f"use one of {', '.join(_WRITERS)} (or 'null' to discard frames)"
        )
    check_output_path(path)


def open_cache_writer(path: str | os.PathLike, options: CacheOptions = CacheOptions()) -> CacheWriter:
    """A writer for ``path`` chosen by its suffix; 'null' (or /dev/null) discards frames."""
    import importlib

    if str(path) in NULL_OUTPUTS:
        from clothtool.io.null import NullCacheWriter

        return NullCacheWriter()
    module, writer, _ = _entry(path)
    return getattr(importlib.import_module(module), writer)(Path(path), options)


def read_cache(path: str | os.PathLike):
    """Open a cache for reading (the format's reader; see its module)."""
    import importlib

    module, _, reader = _entry(path)
    return getattr(importlib.import_module(module), reader)(Path(path))
