"""HDF5 cache: layout, compression options, flushed frames, foreign files."""

from __future__ import annotations

import json
import shutil

import h5py
import numpy as np
import pytest
from test_cache_roundtrip import assert_roundtrip, make_frame, make_header, write_cache

from clothtool.errors import ClothtoolError, FormatError
from clothtool.io.cache import CacheOptions
from clothtool.io.h5cache import H5CacheWriter, read_h5_cache


@pytest.mark.parametrize("compression, filters", [("gzip", ("gzip", True)), ("lzf", ("lzf", True)), ("none", (None, False))])
def test_compression_options(out_dir, compression, filters):
    header = make_header()
    path = out_dir / "shot.h5"
    frames = write_cache(path, header, options=CacheOptions(compression=compression))
    assert_roundtrip(path, header, frames)
    with h5py.File(path, "r") as f:
        for name in ("P", "v"):
            dataset = f["cloth/skirt"][name]
            assert (dataset.compression, dataset.shuffle) == filters
            assert dataset.chunks == (1, 25, 3) and dataset.maxshape == (None, 25, 3)
            assert dataset.shape == (8, 25, 3) and dataset.dtype == np.float32


def test_gzip_is_smaller_than_none(out_dir):
    header = make_header(side=40)
    write_cache(out_dir / "gzip.h5", header)
    write_cache(out_dir / "none.h5", header, options=CacheOptions(compression="none"))
    assert (out_dir / "gzip.h5").stat().st_size < 0.9 * (out_dir / "none.h5").stat().st_size


def test_unknown_compression_is_refused(out_dir):
    with pytest.raises(ClothtoolError, match="unknown compression 'zstd'; use gzip, lzf, none"):
        H5CacheWriter(out_dir / "shot.h5", CacheOptions(compression="zstd"))


def test_layout(out_dir):
    path = out_dir / "shot.h5"
    write_cache(path, make_header(), count=5)
    with h5py.File(path, "r") as f:
        attrs = dict(f.attrs)
        assert attrs["format"] == "clothtool-cache" and attrs["format_version"] == 1
        assert attrs["generator"].startswith("clothtool ")
        assert (attrs["fps"], attrs["start_frame"], attrs["end_frame"], attrs["frame_count"]) == (30.0, 3, 10, 5)
        assert (attrs["meters_per_unit"], attrs["up_axis"]) == (0.01, "Y")
        assert attrs["meta:scene"] == "runway" and json.loads(attrs["cloths"]) == ["skirt", "scarf"]
        skirt = f["cloth/skirt"]
        assert sorted(skirt) == ["P", "extent", "face_vertex_counts", "face_vertex_indices", "face_vertex_uv", "primvars", "rest", "stats", "v"]
        assert sorted(skirt["stats"]) == ["iterations", "residual"] and skirt["stats/residual"].dtype == np.float64
        assert "face_vertex_uv" not in f["cloth/scarf"]
        box = f["collider/box"]
        assert box.attrs["kind"] == "convex" and box["planes"].shape == (6, 4) and box["xform"].shape == (5, 4, 4)
        assert json.loads(f["collider/arm"].attrs["params"]) == {"length": 0.8, "radius0": 0.2, "radius1": 0.1}
        assert f["collider/body/P"].shape == (5, 9, 3)


def test_topology_is_written_without_faces_attribute(out_dir):
    path = out_dir / "shot.h5"
    write_cache(path, make_header(attributes=frozenset({"velocities"}), with_colliders=False))
    with h5py.File(path, "r") as f:
        assert "face_vertex_indices" in f["cloth/skirt"] and "rest" not in f["cloth/skirt"] and "collider" not in f


def test_each_frame_is_flushed(out_dir):
    """A copy of the temporary file taken mid-bake (as after a crash) reads back every frame
    given so far: write_frame returns once its frame is flushed."""
    header = make_header()
    path = out_dir / "shot.h5"
    with H5CacheWriter(path, CacheOptions()) as writer:
        writer.write_header(header)
        for f in (3, 4, 5):
            writer.write_frame(make_frame(header, f))
        (tmp,) = [p for p in out_dir.iterdir() if p.name.startswith(".shot.h5.clothtool-tmp.")]
        shutil.copyfile(tmp, out_dir / "crash.h5")
        writer.commit()
    with read_h5_cache(out_dir / "crash.h5") as cache:
        assert cache.frames == [3, 4, 5] and cache.header.end_frame == 5
        np.testing.assert_array_equal(cache.points("skirt", 5), make_frame(header, 5).points[0])
    with read_h5_cache(path) as cache:
        assert cache.frames == [3, 4, 5]


def test_reader_ignores_rows_beyond_frame_count(out_dir):
    path = out_dir / "shot.h5"
    write_cache(path, make_header())
    with h5py.File(path, "a") as f:
        f.attrs["frame_count"] = 2  # as if the bake died after writing frame 5's rows
    with read_h5_cache(path) as cache:
        assert cache.frames == [3, 4] and len(cache.stats("skirt")["residual"]) == 2


def test_fabric_file_is_refused(out_dir):
    path = out_dir / "skirt.fabric.h5"
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "clothtool-fabric"
    with pytest.raises(FormatError, match="not a clothtool cache .* it is a fabric; give the cache written by 'clothtool bake'"):
        read_h5_cache(path)


def test_other_hdf5_and_newer_versions_are_refused(out_dir):
    other = out_dir / "other.h5"
    with h5py.File(other, "w") as f:
        f["data"] = np.arange(3)
    with pytest.raises(FormatError, match=r"not a clothtool cache \(format attribute is None\)"):
        read_h5_cache(other)
    newer = out_dir / "newer.h5"
    write_cache(newer, make_header())
    with h5py.File(newer, "a") as f:
        f.attrs["format_version"] = 2
    with pytest.raises(FormatError, match="cache format version 2 is not supported"):
        read_h5_cache(newer)
