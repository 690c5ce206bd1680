"""What every cache format shares: checks of what a bake hands a writer, the writers'
temporary-file lifecycle (StreamedCacheWriter), the CacheReader base class with the summary
it gives ``clothtool inspect``, and the summary text.

Used by ``clothtool.io.h5cache`` and ``clothtool.io.usdcache``; loads neither h5py nor pxr.
"""

from __future__ import annotations

import abc
import contextlib
import dataclasses
import json
import os
import re
from pathlib import Path

import numpy as np

from clothtool.errors import ClothtoolError, FormatError
from clothtool.io.atomic import write_error
from clothtool.io.blender_hints import blender_hints
from clothtool.io.cache import CacheHeader, ClothTopology, ColliderInfo, FrameData, partial_path

FORMAT_NAME = "clothtool-cache"
FORMAT_VERSION = 1
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
        # an array's own shape: np.shape and the particle_count property cost 5 us a frame
        shape = array.shape if isinstance(array, np.ndarray) else np.shape(array)
        if shape != (cloth.rest_pos.shape[0], 3):
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
# Shared by every cache writer: the temporary file, the partial file, the commit.


class StreamedCacheWriter(abc.ABC):
    """The lifecycle every cache writer shares. Frames stream into a temporary sibling of the
    output (``_tmp``); ``commit`` renames it into place. Leaving the ``with`` block uncommitted
    (an error, an interrupt, an unstable bake) keeps the whole frames written so far under the
    partial name, or removes the temporary file when there are none or when the file cannot
    be trusted; ``kept`` then says what was kept: (partial path, frame count) or None.

    A format implements ``write_header``, ``write_frame`` and ``_release(keep) -> bool``:
    close its file, first saving it when ``keep``, and say whether the file holds the
    ``frames_written`` whole frames. After a write error (``_fail``) the writer never touches
    its file again except to close it: no more saves or flushes into a file that failed."""

    def __init__(self, path: Path, tmp: Path):
        self.path = path
        self._tmp = tmp
        self._header: CacheHeader | None = None
        self._committed = False
        self._failed = False  # a write into the file failed: its state on disk is suspect
        self._deforming: set[int] = set()  # colliders whose points the last frame wrote
        self.frames_written = 0
        self.kept: tuple[Path, int] | None = None
        self._error: ClothtoolError | None = None  # the write error that failed the file

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if not self._committed:
            self._abandon()

    def _abandon(self, holds_frames: bool | None = None) -> None:
        """Keep the whole frames written so far under the partial name, or nothing; never
        raises (the error that ended the bake is the one to report). ``holds_frames``: what
        ``_release`` said when the file is already released."""
        try:
            if holds_frames is None:
                holds_frames = self._release(keep=self.frames_written > 0)
            if holds_frames and self.frames_written > 0 and self.kept is None:
                partial = partial_path(self.path)
                os.replace(self._tmp, partial)
                self.kept = (partial, self.frames_written)
        except (ClothtoolError, OSError):
            pass
        finally:
            with contextlib.suppress(OSError):
                self._tmp.unlink()

    @abc.abstractmethod
    def _release(self, keep: bool) -> bool:
        """Close the format's file (when ``keep``, first save what it holds to ``_tmp``);
        return whether ``_tmp`` now holds the ``frames_written`` whole frames."""

    def _fail(self, exc: BaseException, doing: str) -> ClothtoolError:
        """Mark the file as failed and give the one-line error for ``exc``."""
        self._failed = True
        self._error = write_error(self.path, exc, doing)
        return self._error

    def _check_new_header(self, header: CacheHeader) -> None:
        if self._header is not None:
            raise ClothtoolError(f"{self.path}: write_header called twice; write the header once")
        validate_header(header, self.path)

    def _check_next_frame(self, frame: FrameData) -> CacheHeader:
        """The header, after checking ``frame`` is the next one it allows."""
        header = self._header
        if header is None:
            raise ClothtoolError(f"{self.path}: write_frame called before write_header")
        if self._failed:
            raise ClothtoolError(f"{self.path}: an earlier write failed; the file is abandoned, write no more frames")
        check_frame(header, frame, header.start_frame + self.frames_written, self.path)
        return header

    def commit(self) -> None:
        if self._header is None:
            raise ClothtoolError(f"{self.path}: commit called before write_header")
        if self._failed:
            raise self._error
        holds_frames = self._release(keep=True)
        if self._failed or not holds_frames:  # the last save or flush failed
            self._abandon(holds_frames)
            raise self._error or ClothtoolError(f"{self.path}: the cache could not be completed; nothing was written under its name")
        try:
            os.replace(self._tmp, self.path)
        except OSError as exc:
            raise write_error(self.path, exc, "renaming the finished cache into place") from None
        self._committed = True


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

    def _check_loaded(self) -> None:
        """Refuse a reconstructed header a writer would have refused (checked against the
        requested frame range, so a partial file passes) and frames that are not consecutive
        from the start frame; raises FormatError naming the file and the element."""
        header, fix = self.header, "the file is damaged, bake it again"
        for key in ("fps", "meters_per_unit"):
            if not np.isfinite(getattr(header, key)):
                raise FormatError(f"{self.path}: {key} is {getattr(header, key)}; it must be a positive finite number, {fix}")
        try:
            validate_header(dataclasses.replace(header, end_frame=self.requested_end_frame), self.path)
        except ClothtoolError as exc:
            raise FormatError(f"{self.path}: invalid cache ({str(exc).removeprefix(f'{self.path}: ')}); {fix}") from None
        expected = list(range(header.start_frame, header.start_frame + len(self.frames)))
        if self.frames != expected or len(self.frames) > self.requested_end_frame - header.start_frame + 1:
            span = f"{self.frames[0]}..{self.frames[-1]}" if self.frames else "none"
            raise FormatError(
                f"{self.path}: frames {span} ({len(self.frames)}) are not consecutive from start frame "
                f"{header.start_frame} to end frame {self.requested_end_frame}; {fix}"
            )

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
            "blender_hints": blender_hints(self.format_label, float(header.fps), float(header.meters_per_unit)),
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
    lines.extend(f"  note       {hint}" for hint in summary["blender_hints"])
    return "\n".join(lines)
