"""The shared cache round trip that every cache format's tests call, and the checks every
format must pass (meshio style: one helper, run across formats).

``make_header``/``make_frame`` build a small bake with every optional part; ``write_cache``
streams it into a writer; ``assert_roundtrip`` reads it back and compares everything.
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from clothtool.errors import ClothtoolError, FormatError
from clothtool.io.cache import (
    CacheHeader,
    CacheOptions,
    ClothTopology,
    ColliderInfo,
    FrameData,
    open_cache_writer,
    partial_path,
    read_cache,
)

SUFFIXES = (".h5", ".hdf5", ".usdc", ".usd", ".usda")
ALL_ATTRIBUTES = frozenset({"velocities", "rest", "faces", "stats", "colliders"})
STATS = ("residual", "iterations")
# A 2x2x2 cube in the scene's convention: outward normal n, solid side n.x < d.
CUBE = np.array([[1, 0, 0, 1], [-1, 0, 0, 1], [0, 1, 0, 1], [0, -1, 0, 1], [0, 0, 1, 1], [0, 0, -1, 1]], np.float64)


def grid(side: int, name: str, uv: bool = True, offset: float = 0.0) -> ClothTopology:
    """A side x side quad grid in the XZ plane with UVs and two painted maps."""
    u, v = np.meshgrid(np.linspace(0, 1, side, dtype=np.float32), np.linspace(0, 1, side, dtype=np.float32))
    rest = np.stack([u.ravel() + offset, np.full(side * side, 1.0, np.float32), v.ravel()], axis=1)
    ids = np.arange(side * side, dtype=np.int32).reshape(side, side)
    quads = np.stack([ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]], axis=-1).reshape(-1, 4)
    indices = quads.ravel().astype(np.int32)
    return ClothTopology(
        name=name,
        rest_pos=rest,
        face_vertex_counts=np.full(len(quads), 4, np.int32),
        face_vertex_indices=indices,
        face_vertex_uv=rest[indices][:, [0, 2]].copy() if uv else None,
        vertex_primvars={"pin": (v.ravel() == 0).astype(np.float32), "max_distance": np.linspace(0, 2, side * side, dtype=np.float32)},
    )


def colliders() -> tuple[ColliderInfo, ...]:
    body = grid(3, "body", uv=False)
    return (
        ColliderInfo("ball", "sphere", {"radius": 0.25}),
        ColliderInfo("arm", "capsule", {"radius0": 0.2, "radius1": 0.1, "length": 0.8}),
        ColliderInfo("leg", "capsule", {"radius0": 0.15, "radius1": 0.15, "length": 0.5}),
        ColliderInfo("floor", "plane", {}),
        ColliderInfo("box", "convex", {"planes": CUBE * [1, 1, 1, 0.5]}),
        ColliderInfo("body", "mesh", {}, body.face_vertex_counts, body.face_vertex_indices, body.rest_pos),
    )


def make_header(
    side: int = 5,
    start: int = 3,
    end: int = 10,
    attributes: frozenset[str] = ALL_ATTRIBUTES,
    with_colliders: bool = True,
) -> CacheHeader:
    return CacheHeader(
        fps=30.0,
        start_frame=start,
        end_frame=end,
        meters_per_unit=0.01,
        up_axis="Y",
        cloths=(grid(side, "skirt"), grid(3, "scarf", uv=False, offset=2.0)),
        colliders=colliders() if with_colliders else (),
        attributes=attributes,
        stats_fields=STATS if "stats" in attributes else (),
        metadata={"scene": "runway", "preset": "production"},
    )


def _xform(frame: int, k: int) -> np.ndarray:
    angle = 0.1 * frame + k
    m = np.eye(4)
    m[0, 0], m[0, 2], m[2, 0], m[2, 2] = np.cos(angle), -np.sin(angle), np.sin(angle), np.cos(angle)
    m[3, :3] = [0.1 * frame, k, -0.05 * frame]  # row-vector convention: translation in the last row
    return m


def make_frame(header: CacheHeader, frame: int) -> FrameData:
    """Deterministic, different for every frame and cloth."""
    t = np.float32(frame - header.start_frame + 1)
    points = tuple(c.rest_pos + np.float32(0.01) * t * np.sin(c.rest_pos + np.float32(i)) for i, c in enumerate(header.cloths))
    velocities = tuple(np.float32(0.3) * np.cos(c.rest_pos * t) for c in header.cloths)
    stats = tuple({"residual": 1.0 / (frame + i), "iterations": float(frame % 7)} for i in range(len(header.cloths)))
    xforms = tuple(_xform(frame, k) for k in range(len(header.colliders)))
    collider_points = tuple(
        c.rest_points * np.float32(1 + 0.01 * t) if c.kind == "mesh" else None for c in header.colliders
    )
    return FrameData(frame, points, velocities, stats, xforms or None, collider_points or None)


def write_cache(
    path: Path, header: CacheHeader, count: int | None = None, options: CacheOptions = CacheOptions(), static: bool = False
) -> list[FrameData]:
    """Write ``count`` frames (all by default) and commit; return the frames written.

    ``static``: mesh colliders get no deformed points (they keep their rest pose).
    """
    frames = [make_frame(header, f) for f in range(header.start_frame, header.end_frame + 1)][:count]
    if static:
        frames = [dataclasses.replace(f, collider_points=None) for f in frames]
    with open_cache_writer(path, options) as writer:
        writer.write_header(header)
        for frame in frames:
            writer.write_frame(frame)
        writer.commit()
    return frames


def assert_roundtrip(path: Path, header: CacheHeader, frames: list[FrameData]) -> None:
    """Everything written reads back: header, topology, every frame's arrays, stats, colliders."""
    with read_cache(path) as cache:
        got = cache.header
        assert cache.frames == [f.frame for f in frames]
        assert (got.fps, got.start_frame, got.end_frame) == (header.fps, header.start_frame, frames[-1].frame)
        assert (got.meters_per_unit, got.up_axis) == (header.meters_per_unit, header.up_axis)
        assert got.metadata == header.metadata
        assert got.stats_fields == header.stats_fields
        assert got.attributes == header.attributes | {"faces"}
        assert [c.name for c in got.cloths] == [c.name for c in header.cloths]
        for want, have in zip(header.cloths, got.cloths):
            _assert_topology(want, have, "rest" in header.attributes)
        for frame in frames:
            for i, cloth in enumerate(header.cloths):
                np.testing.assert_array_equal(cache.points(cloth.name, frame.frame), frame.points[i])
                lo, hi = frame.points[i].min(axis=0), frame.points[i].max(axis=0)
                np.testing.assert_array_equal(cache.extent(cloth.name, frame.frame), np.stack([lo, hi]))
                velocities = cache.velocities(cloth.name, frame.frame)
                if "velocities" in header.attributes:
                    np.testing.assert_array_equal(velocities, frame.velocities[i])
                else:
                    assert velocities is None
        for i, cloth in enumerate(header.cloths):
            stats = cache.stats(cloth.name)
            if "stats" in header.attributes:
                assert list(stats) == list(header.stats_fields)
                for field in header.stats_fields:
                    np.testing.assert_array_equal(stats[field], [f.stats[i][field] for f in frames])
            else:
                assert stats is None
        if "colliders" in header.attributes:
            _assert_colliders(cache, header, frames)
        else:
            assert cache.header.colliders == ()
        summary = cache.summary()
    _assert_summary(summary, path, header, frames)


def _assert_topology(want: ClothTopology, have: ClothTopology, has_rest: bool) -> None:
    np.testing.assert_array_equal(have.face_vertex_counts, want.face_vertex_counts)
    np.testing.assert_array_equal(have.face_vertex_indices, want.face_vertex_indices)
    if want.face_vertex_uv is None:
        assert have.face_vertex_uv is None
    else:
        np.testing.assert_array_equal(have.face_vertex_uv, want.face_vertex_uv)
    assert sorted(have.vertex_primvars) == sorted(want.vertex_primvars)
    for key, values in want.vertex_primvars.items():
        np.testing.assert_array_equal(have.vertex_primvars[key], values)
    assert have.rest_pos.dtype == np.float32 and have.particle_count == want.particle_count
    if has_rest:
        np.testing.assert_array_equal(have.rest_pos, want.rest_pos)


def _assert_colliders(cache, header: CacheHeader, frames: list[FrameData]) -> None:
    got = cache.header.colliders
    assert [(c.name, c.kind) for c in got] == [(c.name, c.kind) for c in header.colliders]
    for want, have in zip(header.colliders, got):
        assert sorted(have.params) == sorted(want.params)
        for key, value in want.params.items():
            np.testing.assert_array_equal(have.params[key], value)
        if want.kind == "mesh":
            np.testing.assert_array_equal(have.face_vertex_indices, want.face_vertex_indices)
            np.testing.assert_array_equal(have.rest_points, want.rest_points)
    for frame in frames:
        for k, collider in enumerate(header.colliders):
            np.testing.assert_array_equal(cache.collider_xform(collider.name, frame.frame), frame.collider_xforms[k])
            moved = cache.collider_points(collider.name, frame.frame)
            expected = frame.collider_points[k] if frame.collider_points else None
            if expected is None:
                assert moved is None
            else:
                np.testing.assert_array_equal(moved, expected)


def _assert_summary(summary: dict, path: Path, header: CacheHeader, frames: list[FrameData]) -> None:
    assert json.loads(json.dumps(summary)) == summary  # JSON-ready
    assert summary["kind"] == "cache" and summary["format_version"] == 1
    assert summary["frames_written"] == len(frames)
    assert summary["file_size_bytes"] == path.stat().st_size
    assert summary["complete"] == (frames[-1].frame == header.end_frame)
    for i, cloth in enumerate(summary["cloths"]):
        everything = np.concatenate([f.points[i] for f in frames])
        assert cloth["points"] == header.cloths[i].particle_count
        np.testing.assert_allclose(cloth["bounding_box"]["min"], everything.min(axis=0))
        np.testing.assert_allclose(cloth["bounding_box"]["max"], everything.max(axis=0))


def files_in(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.iterdir())


def rss_mb() -> float:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS")


def memory_growth_mb(path: Path, points: int, frames: int, options: CacheOptions) -> float:
    """RSS growth (MB) from the first to the last frame of a bake of a ``points`` grid, in a
    fresh process: a test worker that has already freed memory reuses it without growing."""
    import concurrent.futures
    import multiprocessing

    with concurrent.futures.ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        return pool.submit(_memory_growth_mb, path, points, frames, options).result(timeout=600)


def _memory_growth_mb(path: Path, points: int, frames: int, options: CacheOptions) -> float:
    cloth = grid(int(points**0.5), "big")
    header = CacheHeader(24.0, 1, frames, 1.0, "Y", (cloth,), attributes=frozenset())
    wave = np.sin(cloth.rest_pos * 5).astype(np.float32)
    with open_cache_writer(path, options) as writer:
        writer.write_header(header)
        writer.write_frame(FrameData(1, (cloth.rest_pos,)))
        before = rss_mb()
        for f in range(2, frames + 1):
            writer.write_frame(FrameData(f, (cloth.rest_pos + np.float32(0.001 * f) * wave,)))
        after = rss_mb()
        writer.commit()
    return after - before


# ---------------------------------------------------------------------------------------------
# Checks every format passes.


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_roundtrip_every_attribute(out_dir, suffix):
    header = make_header()
    path = out_dir / f"shot{suffix}"
    frames = write_cache(path, header)
    assert files_in(out_dir) == [path.name]  # no temporary file left behind
    assert_roundtrip(path, header, frames)


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_roundtrip_points_only(out_dir, suffix):
    header = make_header(attributes=frozenset(), with_colliders=False)
    path = out_dir / f"shot{suffix}"
    assert_roundtrip(path, header, write_cache(path, header))


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_static_mesh_collider_costs_nothing_per_frame(out_dir, suffix):
    header = make_header()
    path = out_dir / f"shot{suffix}"
    frames = write_cache(path, header, static=True)
    assert_roundtrip(path, header, frames)
    with read_cache(path) as cache:
        np.testing.assert_array_equal(cache.header.colliders[-1].rest_points, header.colliders[-1].rest_points)


@pytest.mark.parametrize("suffix", (".h5", ".usdc"))
def test_deforming_collider_must_give_points_every_frame(out_dir, suffix):
    header = make_header()
    with open_cache_writer(out_dir / f"shot{suffix}") as writer:
        writer.write_header(header)
        writer.write_frame(make_frame(header, 3))
        with pytest.raises(ClothtoolError, match="collider 'body' frame 4 needs deformed points of shape"):
            writer.write_frame(dataclasses.replace(make_frame(header, 4), collider_points=None))


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_same_bake_twice_is_byte_identical(out_dir, suffix):
    header = make_header()
    write_cache(out_dir / f"a{suffix}", header, options=CacheOptions(save_every=3))
    write_cache(out_dir / f"b{suffix}", header, options=CacheOptions(save_every=3))
    assert (out_dir / f"a{suffix}").read_bytes() == (out_dir / f"b{suffix}").read_bytes()


def test_byte_identical_across_processes(out_dir):
    """A fresh interpreter (other hash seeds, other addresses) writes the same bytes."""
    header = make_header()
    for suffix in (".h5", ".usdc", ".usda"):
        write_cache(out_dir / f"here{suffix}", header)
    script = (
        "import sys; from pathlib import Path; sys.path.insert(0, sys.argv[1]);"
        "from test_cache_roundtrip import make_header, write_cache;"
        "[write_cache(Path(sys.argv[2]) / f'there{s}', make_header()) for s in ('.h5', '.usdc', '.usda')]"
    )
    env = {**os.environ, "PYTHONHASHSEED": "12345"}
    subprocess.run([sys.executable, "-c", script, str(Path(__file__).parent), str(out_dir)], check=True, env=env)
    for suffix in (".h5", ".usdc", ".usda"):
        assert (out_dir / f"here{suffix}").read_bytes() == (out_dir / f"there{suffix}").read_bytes(), suffix


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_failed_bake_keeps_partial_frames(out_dir, suffix):
    header = make_header(end=20)
    path = out_dir / f"shot{suffix}"
    frames = [make_frame(header, f) for f in range(3, 7)]
    with pytest.raises(RuntimeError, match="unstable"):
        with open_cache_writer(path, CacheOptions(save_every=3)) as writer:
            writer.write_header(header)
            for frame in frames:
                writer.write_frame(frame)
            raise RuntimeError("unstable")
    assert files_in(out_dir) == [partial_path(path).name]
    assert partial_path(path).name == f"shot.partial{suffix}"
    assert_roundtrip(partial_path(path), header, frames)
    with read_cache(partial_path(path)) as cache:
        summary = cache.summary()
    assert summary["complete"] is False and summary["requested_end_frame"] == 20 and summary["end_frame"] == 6


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_no_frame_no_file(out_dir, suffix):
    with pytest.raises(RuntimeError):
        with open_cache_writer(out_dir / f"shot{suffix}") as writer:
            writer.write_header(make_header())
            raise RuntimeError("diverged before the first frame")
    assert files_in(out_dir) == []


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_frames_out_of_order_or_misshapen_are_refused(out_dir, suffix):
    header = make_header()
    with open_cache_writer(out_dir / f"shot{suffix}") as writer:
        writer.write_header(header)
        with pytest.raises(ClothtoolError, match="expected 3"):
            writer.write_frame(make_frame(header, 4))
        bad = make_frame(header, 3)
        bad = FrameData(3, (bad.points[0][:-1], bad.points[1]), bad.velocities, bad.stats, bad.collider_xforms, bad.collider_points)
        with pytest.raises(ClothtoolError, match="cloth 'skirt' frame 3 points have shape"):
            writer.write_frame(bad)
    assert files_in(out_dir) == []


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_truncated_file_is_refused(out_dir, suffix):
    path = out_dir / f"shot{suffix}"
    write_cache(path, make_header())
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(FormatError) as info:
        read_cache(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and "\n" not in message and "bake it again" in message


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_missing_and_garbage_files_are_refused(out_dir, suffix):
    path = out_dir / f"shot{suffix}"
    with pytest.raises(FormatError, match="not found"):
        read_cache(path)
    path.write_bytes(b"this is not a cache\n" * 10)
    with pytest.raises(FormatError) as info:
        read_cache(path)
    assert str(info.value).startswith(f"{path}: ") and "\n" not in str(info.value)


@pytest.mark.parametrize("suffix", (".h5", ".usdc"))
def test_memory_stays_flat(out_dir, suffix):
    """300 frames of 20k points (69 MB of points) grow the process by far less than that."""
    raw_mb = 300 * 20_000 * 12 / 2**20
    growth = memory_growth_mb(out_dir / f"big{suffix}", 20_000, 300, CacheOptions(compression="none", save_every=10))
    assert growth < raw_mb / 4, f"RSS grew {growth:.0f} MB for {raw_mb:.0f} MB of points"


def test_reader_lookup_errors_name_what_exists(out_dir):
    path = out_dir / "shot.usdc"
    write_cache(path, make_header())
    with read_cache(path) as cache:
        with pytest.raises(ClothtoolError, match="no cloth named 'cape'; the cache has skirt, scarf"):
            cache.points("cape", 3)
        with pytest.raises(ClothtoolError, match=r"frame 42 is not in the cache \(frames written: 3-10\)"):
            cache.points("skirt", 42)
        with pytest.raises(ClothtoolError, match="no collider named 'hat'"):
            cache.collider_xform("hat", 3)


def test_invalid_headers_are_refused(out_dir):
    header = make_header()
    bad_name = ClothTopology("2skirt", header.cloths[0].rest_pos, header.cloths[0].face_vertex_counts, header.cloths[0].face_vertex_indices)
    cases = [
        (CacheHeader(0.0, 1, 2, 1.0, "Y", header.cloths), "fps is 0.0"),
        (CacheHeader(24.0, 1, 2, 1.0, "X", header.cloths), "up axis 'X'"),
        (CacheHeader(24.0, 1, 2, 1.0, "Y", (bad_name,)), "cloth name '2skirt' is not valid"),
        (CacheHeader(24.0, 1, 2, 1.0, "Y", header.cloths[:1] * 2), "cloth name 'skirt' is used twice"),
        (CacheHeader(24.0, 1, 2, 1.0, "Y", header.cloths, (ColliderInfo("c", "cone"),)), "unknown kind 'cone'"),
        (CacheHeader(24.0, 1, 2, 1.0, "Y", header.cloths, attributes=frozenset({"normals"})), "unknown cache attribute 'normals'"),
    ]
    for suffix in (".h5", ".usdc"):
        for bad, message in cases:
            with pytest.raises(ClothtoolError, match=message):
                with open_cache_writer(out_dir / f"shot{suffix}") as writer:
                    writer.write_header(bad)
    assert files_in(out_dir) == []


def test_null_writer_discards_frames():
    header = make_header()
    with open_cache_writer("null") as writer:
        writer.write_header(header)
        writer.write_frame(make_frame(header, 3))
        writer.commit()
    assert writer.path == Path(os.devnull) and writer.frames_written == 1


def test_summary_text_is_short_and_names_the_file(out_dir):
    from clothtool.io.cache_common import format_cache_summary

    header = make_header()
    write_cache(out_dir / "shot.usdc", header, count=4)
    with read_cache(out_dir / "shot.usdc") as cache:
        text = format_cache_summary(cache.summary(), "shot.usdc")
    assert text.splitlines()[0] == "cache shot.usdc (usdc, clothtool-cache v1, partial: 4 of 8 frames)"
    assert "frames     3-6 at 30 fps (4 written)" in text
    assert "skirt: 25 points, 16 faces, uv: yes" in text and "arm (capsule)" in text
    assert len(text.splitlines()) < 12


def test_readers_have_the_same_api():
    from clothtool.io.h5cache import H5CacheReader
    from clothtool.io.usdcache import UsdCacheReader

    def public(cls):
        return {name for name in dir(cls) if not name.startswith("_")}

    assert public(H5CacheReader) - {"format_label"} == public(UsdCacheReader)
    assert {"points", "velocities", "extent", "stats", "collider_xform", "collider_points", "summary", "close"} <= public(UsdCacheReader)
