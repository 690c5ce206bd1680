"""HDF5 caches (``.h5``, ``.hdf5``): one chunk per frame, flushed as it is written.

The layout is specified in ``formats/cache-h5/v1.md``. What every format shares (header
and frame checks, the ``CacheReader`` base, the summary text) lives in
``clothtool.io.cache_common``. h5py loads only when a file is opened.

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
from pathlib import Path

import numpy as np

from clothtool import __version__
from clothtool.errors import ClothtoolError, FormatError
from clothtool.io.atomic import check_output_path, temporary_sibling, write_error
from clothtool.io import cache_units as units
from clothtool.io.cache import CacheHeader, CacheOptions, ClothTopology, ColliderInfo, FrameData
from clothtool.io.cache_common import (
    _NAME,
    CacheReader,
    FORMAT_NAME,
    FORMAT_VERSION,
    StreamedCacheWriter,
    as_points,
    deformed_collider_points,
    points_extent,
    scalar_params_json,
    writes_colliders,
)
from clothtool.io.h5chunks import ENCODED, FrameChunks, GzipChunkEncoder, SeriesChunks
from clothtool.io.h5safe import check_hdf5_file, check_layout, read_dataset
from clothtool.io.hdf5_files import create_hdf5


# ---------------------------------------------------------------------------------------------
# The HDF5 writer.

_COMPRESSION = {
    "gzip": dict(compression="gzip", compression_opts=1, shuffle=True),
    "lzf": dict(compression="lzf", shuffle=True),
    "none": {},
}
# Small per-frame series (extent, stats, transforms): chunks of this many frames, uncompressed.
_SERIES_CHUNK = 64


class H5CacheWriter(StreamedCacheWriter):
    """Stream frames into an HDF5 cache; see the module docstring and formats/cache-h5/v1.md."""

    def __init__(self, path: Path, options: CacheOptions = CacheOptions()):
        path = check_output_path(path)
        if options.compression not in _COMPRESSION:
            raise ClothtoolError(f"{path}: unknown compression '{options.compression}'; use {', '.join(_COMPRESSION)}")
        super().__init__(path, temporary_sibling(path))
        self._filters = _COMPRESSION[options.compression]
        self._compression = options.compression
        self._file = None
        self._velocities = False
        # Per cloth (P, v or None, extent series, [(stats field, series)]); per collider its
        # xform series: opened once (looking a path up costs as much as writing a row).
        # ``frame_count`` is rewritten every frame from one array, its HDF5 type given.
        self._cloth_rows: list[tuple] = []
        self._collider_rows: list[SeriesChunks] = []
        self._frame_count_attr = None  # the root attribute rewritten every frame, opened once
        self._frame_count_value = np.zeros((), np.int64)
        self._frame_count_type = None
        self._last_extents: list[np.ndarray] = []  # per cloth, of the last frame flushed
        # Per per-frame dataset, its gzip chunks' encoder (a buffer reused every frame):
        # in the order _write_rows stores them (per cloth P then v), then per deforming collider.
        self._encoders: list[GzipChunkEncoder] = []
        self._collider_encoders: dict[int, GzipChunkEncoder] = {}

    def write_header(self, header: CacheHeader) -> None:
        self._check_new_header(header)
        self._header = header
        try:
            self._file = f = create_hdf5(self._tmp)  # a full disk raises at the write that meets it
        except OSError as exc:
            raise write_error(self.path, exc, "creating the HDF5 file") from None
        try:
            _write_root_attrs(f, header)
            for cloth in header.cloths:
                self._create_cloth(f.create_group(f"cloth/{cloth.name}"), cloth, header)
            if writes_colliders(header):
                for collider in header.colliders:
                    self._create_collider(f.create_group(f"collider/{collider.name}"), collider)
            f.flush()
            self._open_rows(f, header)
        except (OSError, RuntimeError) as exc:
            raise self._fail(exc, "writing the header") from None

    def _series(self, group, name: str, shape: tuple, dtype, unit: str, per_frame_chunk: bool = False):
        # Datasets grow one frame at a time, so a partial file holds exactly the frames written.
        chunks = (1, *shape) if per_frame_chunk else (_SERIES_CHUNK, *shape)
        filters = self._filters if per_frame_chunk else {}
        dataset = group.create_dataset(name, shape=(0, *shape), maxshape=(None, *shape), dtype=dtype, chunks=chunks, **filters)
        dataset.attrs["units"] = unit
        return dataset

    def _open_rows(self, f, header: CacheHeader) -> None:
        """The per-frame datasets and the root attribute ``frame_count``, opened once for
        every frame to write into."""
        from h5py import h5a, h5t

        self._frame_count_attr = h5a.open(f.id, b"frame_count")
        self._frame_count_type = h5t.NATIVE_INT64
        self._velocities = "velocities" in header.attributes
        stats_fields = header.stats_fields if "stats" in header.attributes else ()
        self._cloth_rows = []
        for cloth in header.cloths:
            g = f["cloth"][cloth.name]
            stats = [(field, SeriesChunks(g["stats"][field])) for field in stats_fields]
            velocities = FrameChunks(g["v"]) if self._velocities else None
            self._cloth_rows.append((FrameChunks(g["P"]), velocities, SeriesChunks(g["extent"]), stats))
            if self._compression == "gzip":
                size = 3 * cloth.particle_count
                self._encoders += [GzipChunkEncoder(size) for _ in range(2 if self._velocities else 1)]
        if writes_colliders(header):
            self._collider_rows = [SeriesChunks(f["collider"][collider.name]["xform"]) for collider in header.colliders]

    def _create_cloth(self, g, cloth: ClothTopology, header: CacheHeader) -> None:
        n, mpu = cloth.particle_count, header.meters_per_unit
        self._series(g, "P", (n, 3), np.float32, units.lengths(mpu), per_frame_chunk=True)
        if "velocities" in header.attributes:
            self._series(g, "v", (n, 3), np.float32, units.velocities(mpu), per_frame_chunk=True).attrs["frame"] = units.WORLD_FRAME
        self._series(g, "extent", (2, 3), np.float32, units.lengths(mpu))
        if "rest" in header.attributes:
            _constant(g, "rest", as_points(cloth.rest_pos), units.lengths(mpu))
        # Topology is always written: the DCCs need it to rebuild the mesh.
        _constant(g, "face_vertex_counts", np.asarray(cloth.face_vertex_counts, np.int32), units.FACE_VERTEX_COUNTS)
        _constant(g, "face_vertex_indices", np.asarray(cloth.face_vertex_indices, np.int32), units.FACE_VERTEX_INDICES)
        if cloth.face_vertex_uv is not None:
            _constant(g, "face_vertex_uv", np.asarray(cloth.face_vertex_uv, np.float32), units.FACE_VERTEX_UV)
        if cloth.vertex_primvars:
            primvars = g.create_group("primvars")
            for key in sorted(cloth.vertex_primvars):
                _constant(primvars, key, np.asarray(cloth.vertex_primvars[key], np.float32), units.primvar_units(key, mpu))
        if "stats" in header.attributes and header.stats_fields:
            stats = g.create_group("stats")
            for field in header.stats_fields:
                unit, frame = units.stat_units(field)
                dataset = self._series(stats, field, (), np.float64, unit)
                if frame is not None:
                    dataset.attrs["frame"] = frame

    def _create_collider(self, g, collider: ColliderInfo) -> None:
        mpu = self._header.meters_per_unit
        g.attrs["kind"] = collider.kind
        g.attrs["params"] = scalar_params_json(collider.params)
        g.attrs["params_units"] = units.lengths(mpu)
        self._series(g, "xform", (4, 4), np.float64, units.xform(mpu))
        for key in sorted(collider.params):
            if np.ndim(collider.params[key]):  # convex "planes": (m,4)
                _constant(g, key, np.asarray(collider.params[key], np.float64), units.planes(mpu))
        if collider.kind == "mesh":
            _constant(g, "face_vertex_counts", np.asarray(collider.face_vertex_counts, np.int32), units.FACE_VERTEX_COUNTS)
            _constant(g, "face_vertex_indices", np.asarray(collider.face_vertex_indices, np.int32), units.FACE_VERTEX_INDICES)
            _constant(g, "rest_points", as_points(collider.rest_points), units.lengths(mpu))

    def write_frame(self, frame: FrameData) -> None:
        """Write ``frame`` and flush it: when this returns, the file holds it whole. Its chunks
        are all encoded before any of it is written; a failed encoding or write raises naming
        the frame, and the frames flushed before it stay whole."""
        header = self._check_next_frame(frame)
        moved = {}
        if writes_colliders(header):  # checked before anything of the frame is written
            moved = deformed_collider_points(header, frame, self._deforming if self.frames_written else None, self.path)
        chunks, extents = self._encode(frame, moved)
        k = self.frames_written
        try:
            self._write_rows(frame, k, chunks, extents, moved)
        except (OSError, RuntimeError) as exc:  # h5py raises RuntimeError when a flush fails
            raise self._fail(exc, f"writing frame {frame.frame}") from None
        self._last_extents = extents
        self._deforming = set(moved)
        self.frames_written = k + 1

    def _encode(self, frame: FrameData, moved: dict[int, np.ndarray]) -> tuple[list, list]:
        """The frame's per-frame chunks as stored (in the order ``_write_rows`` takes them:
        per cloth P then v, then the deforming colliders' points) and each cloth's extent."""
        from clothtool.io.extent_kernel import frame_extent

        chunks, extents = [], []
        velocities = frame.velocities if self._velocities else None
        encoders = iter(self._encoders)
        try:
            for i in range(len(self._cloth_rows)):
                points = as_points(frame.points[i])
                extents.append(frame_extent(points))
                chunks.append(self._stored(points, next(encoders, None)))
                if velocities is not None:
                    chunks.append(self._stored(as_points(velocities[i]), next(encoders, None)))
            for i in sorted(moved):
                if self._compression == "gzip" and i not in self._collider_encoders:
                    self._collider_encoders[i] = GzipChunkEncoder(moved[i].size)
                chunks.append(self._stored(moved[i], self._collider_encoders.get(i)))
        except Exception as exc:  # the encoding's error: nothing of the frame is in the file
            self._failed = True
            self._error = ClothtoolError(f"{self.path}: compressing frame {frame.frame} failed ({type(exc).__name__}: {exc}); bake it again")
            raise self._error from None
        return chunks, extents

    def _stored(self, array: np.ndarray, encoder: GzipChunkEncoder | None):
        """A per-frame chunk as ``_store`` takes it: for gzip the encoded bytes (h5chunks; a
        view of ``encoder``'s buffer, written before that encoder runs again); otherwise the
        array itself, written in this frame's ``_write_rows`` (before the caller can change
        it): as it is for "none", through h5py's filter for lzf.

        The encoding runs on the caller's thread: it costs ~0.025 ms per 128^2 chunk, less
        than handing it to a worker thread did in wake-ups and GIL handoffs (and the CPU time
        is the same on any thread)."""
        return array if encoder is None else encoder.encode(array)

    def _write_rows(self, frame: FrameData, k: int, chunks: list, extents: list, moved: dict[int, np.ndarray]) -> None:
        """Row ``k`` of every per-frame dataset, then the frame count, then a flush (in the
        order of the first version: the same frames give the same bytes)."""
        chunk = iter(chunks)
        for points, velocities, _, _ in self._cloth_rows:
            self._store(points, k, next(chunk))
            if velocities is not None:
                self._store(velocities, k, next(chunk))
        for i, ((_, _, extent, stats), box) in enumerate(zip(self._cloth_rows, extents)):
            extent.write(k, box)
            for field, series in stats:
                series.write(k, float(frame.stats[i][field]))
        for i, xform in enumerate(self._collider_rows):
            xform.write(k, np.asarray(frame.collider_xforms[i], np.float64))
        for i in sorted(moved):
            self._store(self._collider_points(i, k, moved[i].shape), k, next(chunk))
        self._write_frame_count(k + 1)
        # Flushing every frame keeps memory flat and leaves a readable file after a crash.
        self._file.flush()

    def _collider_points(self, i: int, k: int, shape: tuple):
        """The deforming mesh collider ``i``'s points dataset, created on the first frame (only
        deforming meshes get one)."""
        g = self._file["collider"][self._header.colliders[i].name]
        if k == 0:
            self._series(g, "P", shape, np.float32, units.lengths(self._header.meters_per_unit), per_frame_chunk=True)
        return FrameChunks(g["P"])

    def _write_frame_count(self, count: int) -> None:
        """Rewrite the root attribute ``frame_count`` in place (h5py's ``attrs[...] =``
        recreates it: 4x the cost; with its type named h5py does not derive one per call)."""
        self._frame_count_value[()] = count
        self._frame_count_attr.write(self._frame_count_value, mtype=self._frame_count_type)

    def _store(self, chunks: FrameChunks, k: int, stored) -> None:
        if self._compression in ENCODED:
            chunks.write(k, stored)
        else:
            _append(chunks.dataset, k, stored)

    def _release(self, keep: bool) -> bool:
        # Flushed every frame, the file holds all it should: trimmed and closed either way.
        self._cloth_rows, self._collider_rows = [], []
        self._frame_count_attr = None
        f, self._file = self._file, None
        if f is None:
            return False
        if not self._failed:
            try:
                _trim(f, self.frames_written)  # an interrupt may have come in the middle of a frame
                f.attrs["frame_count"] = self.frames_written
                f.flush()
                f.close()
                return True
            except (OSError, RuntimeError) as exc:
                self._fail(exc, "closing the file")
        # A write failed: close without trusting the file, then keep it only if it reads back
        # the frames flushed before the failure.
        with contextlib.suppress(Exception):
            _trim(f, self.frames_written)
            f.attrs["frame_count"] = self.frames_written
        with contextlib.suppress(Exception):
            f.close()
        return keep and self._reads_back_flushed_frames()

    def _reads_back_flushed_frames(self) -> bool:
        """Whether ``_tmp`` holds exactly the frames flushed, the last one as it was written."""
        try:
            with H5CacheReader(self._tmp) as cache:
                if len(cache.frames) != self.frames_written or len(self._last_extents) != len(cache.header.cloths):
                    return False
                last = cache.frames[-1]
                for cloth, extent in zip(cache.header.cloths, self._last_extents):
                    stored = cache.extent(cloth.name, last)
                    read = points_extent(cache.points(cloth.name, last))
                    if not (np.array_equal(stored, extent) and np.array_equal(read, extent)):
                        return False
        except (ClothtoolError, OSError, RuntimeError):
            return False
        return True


def _constant(group, name: str, data: np.ndarray, unit: str) -> None:
    """A dataset written once, with what its numbers mean."""
    group.create_dataset(name, data=data).attrs["units"] = unit


def _append(dataset, k: int, value) -> None:
    """Grow a per-frame dataset to ``k + 1`` rows and write row ``k`` through HDF5's own
    call: h5py's ``dataset[k] = value`` spends 3x as long parsing the selection."""
    from h5py import h5s

    dsid = dataset.id
    tail = dsid.shape[1:]
    dsid.set_extent((k + 1, *tail))  # h5py's resize() costs 7x as much in checks
    row = np.ascontiguousarray(value, dataset.dtype).reshape(1, *tail)
    file_space = dsid.get_space()
    file_space.select_hyperslab((k,) + (0,) * len(tail), row.shape)
    dsid.write(h5s.create_simple(row.shape), file_space, row)


def _trim(f, frames: int) -> None:
    """Shrink every per-frame dataset to ``frames`` (after a failure in the middle of a frame)."""

    def visit(name, obj):
        if hasattr(obj, "maxshape") and obj.maxshape and obj.maxshape[0] is None and obj.shape[0] > frames:
            if not _has_unwritten_chunk(obj, frames):
                obj.resize(frames, axis=0)
            # else: the rows stay, beyond frame_count, where readers ignore them

    f.visititems(visit)


def _has_unwritten_chunk(dataset, frames: int) -> bool:
    """Whether a per-frame chunk past ``frames`` was never written (its write failed, the
    dataset already grown). Shrinking over it fails in HDF5 ("B-tree key not found") and can
    drop the chunk before it: a frame that was flushed whole."""
    if dataset.chunks is None or dataset.chunks[0] != 1:
        return False
    rest = (0,) * (dataset.ndim - 1)
    return any(dataset.id.get_chunk_info_by_coord((row, *rest)).byte_offset is None for row in range(frames, dataset.shape[0]))


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
        except (OSError, KeyError, ValueError, TypeError, RuntimeError) as exc:
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
            shown = repr(fmt) if len(repr(fmt)) <= 40 else repr(fmt)[:37] + "..."
            _fail(path, f"not a clothtool cache (format attribute is {shown}); {hint}")
        version = int(f.attrs.get("format_version", -1))
        if version != FORMAT_VERSION:
            _fail(path, f"cache format version {version} is not supported (this clothtool reads {FORMAT_VERSION}); bake it again")
        # Before any data is read: nothing may point outside the file or claim more bytes
        # than the file holds.
        check_hdf5_file(f, path, _FIX)
        names = _name_list(f, path, "cloths")
        for name in names:
            if f"cloth/{name}/P" not in f:
                _fail(path, f"cloth '{name}' is missing; the file is truncated or damaged, bake it again")
        start = _int_attr(f, path, "start_frame")
        self.requested_end_frame = _int_attr(f, path, "end_frame")
        if self.requested_end_frame < start:
            _fail(path, f"root attribute 'end_frame' ({self.requested_end_frame}) is before 'start_frame' ({start}); {_FIX}")
        # A crash between writing a frame and updating frame_count leaves extra rows: ignore them.
        count = _int_attr(f, path, "frame_count")
        if not 0 <= count <= self.requested_end_frame - start + 1:
            _fail(path, f"root attribute 'frame_count' is {count}, outside 0..{self.requested_end_frame - start + 1} (start_frame to end_frame); {_FIX}")
        count = min([count] + [f[f"cloth/{name}/P"].shape[0] for name in names])
        self.frames = list(range(start, start + count))
        fps = _float_attr(f, path, "fps")
        meters_per_unit = _float_attr(f, path, "meters_per_unit")
        present = set(_name_list(f, path, "attributes", names=False))
        self.header = CacheHeader(
            fps=fps,
            start_frame=start,
            end_frame=start + count - 1,
            meters_per_unit=meters_per_unit,
            up_axis=str(f.attrs["up_axis"]),
            cloths=tuple(self._cloth_topology(name, f[f"cloth/{name}"]) for name in names),
            colliders=tuple(self._collider_info(name, f[f"collider/{name}"]) for name in _name_list(f, path, "colliders")),
            attributes=frozenset(present),
            stats_fields=tuple(_name_list(f, path, "stats_fields")),
            metadata={k[5:]: str(v) for k, v in sorted(f.attrs.items()) if k.startswith("meta:")},
        )
        self._check_loaded()
        for cloth in self.header.cloths:
            self._check_series(cloth)

    def _check_series(self, cloth: ClothTopology) -> None:
        """Per-frame datasets match the cloth's point count and hold every frame (no data read)."""
        g, n, count = self._file["cloth"][cloth.name], cloth.particle_count, len(self.frames)
        series = [("P", np.float32, (n, 3)), ("extent", np.float32, (2, 3))]
        series += [("v", np.float32, (n, 3))] if "v" in g else []
        series += [(f"stats/{field}", np.float64, ()) for field in self.header.stats_fields if "stats" in g]
        for key, dtype, shape in series:
            where = f"cloth/{cloth.name}/{key}"
            if key not in g:
                _fail(self.path, f"dataset '{where}' is missing; {_FIX}")
            check_layout(g[key], self.path, where, dtype, 1 + len(shape), _FIX)
            if g[key].shape[1:] != shape or g[key].shape[0] < count:
                _fail(self.path, f"dataset '{where}' has shape {g[key].shape}, expected ({count}, {', '.join(map(str, shape))}) for {n} points; {_FIX}".replace(", )", ")"))

    def _cloth_topology(self, name: str, g) -> ClothTopology:
        path = self.path
        p = g["P"]
        check_layout(p, path, f"cloth/{name}/P", np.float32, 3, _FIX, width=3)
        n = p.shape[1]
        if "rest" in g:
            rest = read_dataset(g["rest"], path, f"cloth/{name}/rest", np.float32, 2, _FIX, width=3)
        elif self.frames:
            rest = p[0]  # no rest pose written: the first frame stands in for it
        else:
            rest = np.zeros((n, 3), np.float32)
        if rest.shape[0] != n:
            _fail(path, f"cloth '{name}' has {rest.shape[0]} rest points but {n} points per frame; {_FIX}")
        primvars = {}
        if "primvars" in g:
            for key in g["primvars"]:
                primvars[key] = read_dataset(g["primvars"][key], path, f"cloth/{name}/primvars/{key}", np.float32, 1, _FIX)

        def topology(key, dtype, ndim, width=None):
            return read_dataset(g[key], path, f"cloth/{name}/{key}", dtype, ndim, _FIX, width)

        return ClothTopology(
            name=name,
            rest_pos=np.asarray(rest, np.float32),
            face_vertex_counts=topology("face_vertex_counts", np.int32, 1),
            face_vertex_indices=topology("face_vertex_indices", np.int32, 1),
            face_vertex_uv=topology("face_vertex_uv", np.float32, 2, 2) if "face_vertex_uv" in g else None,
            vertex_primvars=primvars,
        )

    def _collider_info(self, name: str, g) -> ColliderInfo:
        path = self.path
        params = json.loads(g.attrs["params"])
        if not isinstance(params, dict):
            _fail(path, f"collider '{name}' attribute 'params' is not a JSON object; {_FIX}")
        check_layout(g["xform"], path, f"collider/{name}/xform", np.float64, 3, _FIX)
        if g["xform"].shape[1:] != (4, 4) or g["xform"].shape[0] < len(self.frames):
            _fail(path, f"dataset 'collider/{name}/xform' has shape {g['xform'].shape}, expected ({len(self.frames)}, 4, 4); {_FIX}")
        for key in g:
            if key not in ("xform", "P", "face_vertex_counts", "face_vertex_indices", "rest_points"):
                params[key] = read_dataset(g[key], path, f"collider/{name}/{key}", np.float64, 2, _FIX, width=4)
        mesh = str(g.attrs["kind"]) == "mesh"

        def mesh_data(key, dtype, ndim, width=None):
            return read_dataset(g[key], path, f"collider/{name}/{key}", dtype, ndim, _FIX, width) if mesh else None

        info = ColliderInfo(
            name=name,
            kind=str(g.attrs["kind"]),
            params=params,
            face_vertex_counts=mesh_data("face_vertex_counts", np.int32, 1),
            face_vertex_indices=mesh_data("face_vertex_indices", np.int32, 1),
            rest_points=mesh_data("rest_points", np.float32, 2, 3),
        )
        if mesh and "P" in g:
            check_layout(g["P"], path, f"collider/{name}/P", np.float32, 3, _FIX)
            if g["P"].shape[1:] != info.rest_points.shape or g["P"].shape[0] < len(self.frames):
                _fail(path, f"dataset 'collider/{name}/P' has shape {g['P'].shape}, expected ({len(self.frames)}, {info.rest_points.shape[0]}, 3); {_FIX}")
        return info

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


_FIX = "the file is damaged, bake it again"


def _int_attr(f, path, key: str) -> int:
    value = f.attrs[key]
    if np.ndim(value) or np.asarray(value).dtype.kind not in "iu":
        _fail(path, f"root attribute '{key}' must be an integer, got {np.asarray(value).dtype} {np.shape(value)}; {_FIX}")
    return int(value)


def _float_attr(f, path, key: str) -> float:
    value = f.attrs[key]
    if np.ndim(value) or np.asarray(value).dtype.kind not in "iuf" or not np.isfinite(value) or not value > 0:
        _fail(path, f"root attribute '{key}' must be a positive finite number, got {value if np.ndim(value) == 0 else np.shape(value)}; {_FIX}")
    return float(value)


def _name_list(f, path, key: str, names: bool = True) -> list[str]:
    """A JSON list of strings from a root attribute; ``names`` requires group-safe names (no
    '/' or '..' that would reach elsewhere in the file)."""
    value = f.attrs[key]
    try:
        items = json.loads(value)
    except (TypeError, ValueError):
        items = None
    if not isinstance(items, list) or not all(isinstance(item, str) for item in items):
        _fail(path, f"root attribute '{key}' must be a JSON list of strings; {_FIX}")
    if names:
        bad = [item for item in items if not _NAME.match(item)]
        if bad:
            _fail(path, f"root attribute '{key}' holds the invalid name {bad[0][:40]!r}; {_FIX}")
    return items
