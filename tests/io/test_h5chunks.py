"""Pre-compressed HDF5 chunks: the same data HDF5's own shuffle+deflate filters give, any
reader inflates them, the same input gives the same bytes, and the encoding's errors
and the caller's reused arrays are handled."""

from __future__ import annotations

import hashlib
import shutil
import struct
import subprocess
import zlib

import h5py
import numpy as np
import pytest
from test_cache_roundtrip import assert_roundtrip, make_frame, make_header, write_cache

from clothtool.errors import ClothtoolError
from clothtool.io.cache import CacheOptions
from clothtool.io.h5cache import H5CacheWriter, read_h5_cache
from clothtool.io.h5chunks import GzipChunkEncoder, SeriesChunks, encode_chunk, shuffle
from clothtool.io.hdf5_files import create_hdf5


def test_shuffle_groups_each_byte_of_the_elements():
    # Two float32 elements, bytes a0 a1 a2 a3 b0 b1 b2 b3 -> a0 b0 a1 b1 a2 b2 a3 b3 (HDF5's shuffle).
    array = np.frombuffer(bytes(range(8)), np.float32)
    assert shuffle(array).tobytes() == bytes([0, 4, 1, 5, 2, 6, 3, 7])


@pytest.mark.parametrize("dtype", ["<f4", ">f4", "<f8", "<i2"])
def test_shuffle_matches_a_numpy_transpose_of_the_element_bytes(dtype):
    """float32 through the compiled loop, other element sizes and byte orders through numpy."""
    points = np.random.default_rng(3).normal(size=(1001, 3)).astype(dtype)
    size = points.dtype.itemsize
    planes = shuffle(points)
    assert planes.shape == (size, 3003)
    np.testing.assert_array_equal(planes, points.view(np.uint8).reshape(-1, size).T)


def stream_blocks(stream: bytes) -> list[int]:
    """The BTYPE of each deflate block of a zlib stream whose stored blocks come first."""
    assert stream[:2] == b"\x78\x01" and int.from_bytes(stream[:2], "big") % 31 == 0
    types, at = [], 2
    while stream[at] & 0b111 == 0:  # stored, not final: LEN and NLEN then the bytes
        length, nlength = struct.unpack("<HH", stream[at + 1 : at + 5])
        assert length ^ nlength == 0xFFFF
        types.append(0)
        at += 5 + length
    types.append((stream[at] >> 1) & 0b11)  # the deflated plane's first block
    return types


@pytest.mark.parametrize("points", [1, 5, 16384, 21846, 40000])
def test_mantissa_planes_are_stored_and_the_exponent_plane_deflated(points):
    """Planes 0-2 go as stored blocks of at most 65535 bytes, plane 3 through deflate; the
    stream inflates (zlib checks the Adler-32) to the shuffled bytes at every size, including
    plane lengths on and across the stored-block limit."""
    array = np.random.default_rng(points).normal(size=(points, 3)).astype(np.float32)
    stream = encode_chunk(array, "gzip")
    assert zlib.decompress(stream) == array.view(np.uint8).reshape(-1, 4).T.tobytes()
    stored_bytes = 3 * array.size
    types = stream_blocks(stream)
    assert types[:-1] == [0] * -(-stored_bytes // 65535) and types[-1] in (1, 2)
    # The stored part is the three low planes as they are; the exponent plane shrinks.
    assert len(stream) < stored_bytes + array.size + 5 * len(types) + 6 + 16


@pytest.mark.parametrize("points", [1, 5, 16384, 21845, 21846, 43690, 100000])
def test_the_encoder_gives_encode_chunks_bytes_frame_after_frame(points):
    """Stored-block headers written once, the planes shuffled into the blocks in runs cut
    where a block ends inside a plane (21845 and 43690 points end blocks on a plane's
    end): the same bytes as encode_chunk for every frame through the one buffer."""
    rng = np.random.default_rng(points)
    encoder = GzipChunkEncoder(3 * points)
    for _ in range(3):
        array = rng.normal(size=(points, 3)).astype(np.float32)
        assert bytes(encoder.encode(array)) == encode_chunk(array, "gzip")


@pytest.mark.parametrize("room", [GzipChunkEncoder.deflated_room, lambda elements: 0])
def test_the_encoder_keeps_an_incompressible_exponent_plane_whole(monkeypatch, room):
    """Random bit patterns give deflate nothing to shrink: the deflated plane fits the room
    kept for it, and where it does not (no room kept) the buffer grows."""
    monkeypatch.setattr(GzipChunkEncoder, "deflated_room", staticmethod(room))
    for points in (30000, 100000):
        array = np.random.default_rng(points).integers(0, 2**32, size=(points, 3), dtype=np.uint32).view(np.float32)
        encoder = GzipChunkEncoder(array.size)
        for _ in range(2):
            stream = bytes(encoder.encode(array))
            assert stream == encode_chunk(array, "gzip")
            assert zlib.decompress(stream) == array.view(np.uint8).reshape(-1, 4).T.tobytes()


def test_the_encoder_refuses_a_chunk_of_another_size_or_type():
    encoder = GzipChunkEncoder(6)
    for bad in (np.zeros((3, 3), np.float32), np.zeros((2, 3), np.float64), np.zeros((3, 2), np.float32).T):
        with pytest.raises(ValueError, match="a chunk is 6 contiguous float32 values"):
            encoder.encode(bad)


def h5py_filtered_chunk(tmp_path, array: np.ndarray, compression: str) -> bytes:
    """The chunk HDF5's own filter pipeline stores for ``array`` (one frame)."""
    options = {"gzip": dict(compression="gzip", compression_opts=1, shuffle=True), "none": {}}[compression]
    with create_hdf5(tmp_path / f"reference-{compression}.h5") as f:
        dataset = f.create_dataset("P", data=array[None], maxshape=(None, *array.shape), chunks=(1, *array.shape), **options)
        return dataset.id.read_direct_chunk((0, 0, 0))[1]


@pytest.mark.parametrize("compression", ["gzip", "none"])
def test_our_chunk_inflates_to_the_bytes_of_hdf5s_own_filters(tmp_path, compression):
    points = np.random.default_rng(7).normal(size=(500, 3)).astype(np.float32)
    ours, theirs = encode_chunk(points, compression), h5py_filtered_chunk(tmp_path, points, compression)
    inflate = zlib.decompress if compression == "gzip" else bytes
    assert inflate(ours) == inflate(theirs)
    if compression == "gzip":  # the shuffled bytes, as HDF5 transposes them
        assert inflate(ours) == points.view(np.uint8).reshape(-1, 4).T.tobytes()
        assert len(ours) < 0.95 * points.nbytes


@pytest.mark.parametrize("compression", ["gzip", "none"])
def test_the_cache_reads_back_through_hdf5s_filters(out_dir, compression):
    header = make_header()
    path = out_dir / "shot.h5"
    frames = write_cache(path, header, options=CacheOptions(compression=compression))
    assert_roundtrip(path, header, frames)
    with h5py.File(path, "r") as f:  # h5py's plain read: HDF5 inflates and unshuffles each chunk
        points = f["cloth/skirt/P"]
        assert points.id.get_chunk_info(0).filter_mask == 0  # every declared filter applied
        np.testing.assert_array_equal(points[...], np.stack([frame.points[0] for frame in frames]))
        np.testing.assert_array_equal(f["collider/body/P"][2], frames[2].collider_points[-1])  # a deforming mesh


@pytest.mark.skipif(shutil.which("h5dump") is None, reason="h5dump (hdf5-tools) is not installed")
def test_h5dump_reads_the_compressed_points(out_dir):
    """The HDF5 command-line tools (their own HDF5 build) inflate the chunks too."""
    header = make_header()
    path = out_dir / "shot.h5"
    frames = write_cache(path, header)
    for name, expected in (("P", [frame.points[0] for frame in frames]), ("v", [frame.velocities[0] for frame in frames])):
        dump = out_dir / f"{name}.bin"
        subprocess.run(["h5dump", "-d", f"/cloth/skirt/{name}", "-b", "LE", "-o", str(dump), str(path)], capture_output=True, check=True)
        np.testing.assert_array_equal(np.fromfile(dump, "<f4"), np.stack(expected).ravel())


def test_same_frames_same_bytes(out_dir):
    header = make_header(side=30)
    digests = []
    for name in ("a.h5", "b.h5"):
        write_cache(out_dir / name, header)
        digests.append(hashlib.sha256((out_dir / name).read_bytes()).hexdigest())
    assert digests[0] == digests[1]


def test_arrays_changed_after_write_frame_do_not_reach_the_file(out_dir):
    """The solver reuses its arrays for the next frame while this one still compresses."""
    header = make_header()
    frames = [make_frame(header, f) for f in (3, 4)]
    with H5CacheWriter(out_dir / "shot.h5", CacheOptions()) as writer:
        writer.write_header(header)
        for frame in frames:
            expected = [p.copy() for p in frame.points], [v.copy() for v in frame.velocities]
            writer.write_frame(frame)
            for array in (*frame.points, *frame.velocities):
                array[...] = np.nan
        writer.commit()
    with read_h5_cache(out_dir / "shot.h5") as cache:
        np.testing.assert_array_equal(cache.points("skirt", 4), expected[0][0])
        np.testing.assert_array_equal(cache.velocities("scarf", 4), expected[1][1])


def test_an_encoding_error_fails_the_frame_at_the_next_write(out_dir, monkeypatch):
    header = make_header()
    encode, calls = GzipChunkEncoder.encode, []

    def encode_failing_for_frame_5(encoder, array):
        calls.append(len(calls))
        if len(calls) > 2 * 5:  # frames 3 and 4 (two cloths' P and v, the body's points), then frame 5 fails
            raise MemoryError("no room for the compressed chunk")
        return encode(encoder, array)

    monkeypatch.setattr(GzipChunkEncoder, "encode", encode_failing_for_frame_5)
    writer = H5CacheWriter(out_dir / "shot.h5", CacheOptions())
    with pytest.raises(ClothtoolError, match=r"shot\.h5: compressing frame 5 failed \(MemoryError: no room for the compressed chunk\)"):
        with writer:
            writer.write_header(header)
            for f in range(3, 11):
                writer.write_frame(make_frame(header, f))
    assert writer.frames_written == 2 and writer.kept == (out_dir / "shot.partial.h5", 2)
    with read_h5_cache(out_dir / "shot.partial.h5") as cache:
        assert cache.frames == [3, 4]
        np.testing.assert_array_equal(cache.points("scarf", 4), make_frame(header, 4).points[1])


def test_an_encoding_error_on_the_last_frame_fails_the_commit(out_dir, monkeypatch):
    header = make_header(start=1, end=2)
    encode = GzipChunkEncoder.encode
    writer = H5CacheWriter(out_dir / "shot.h5", CacheOptions())
    with pytest.raises(ClothtoolError, match=r"compressing frame 2 failed"):
        with writer:
            writer.write_header(header)
            writer.write_frame(make_frame(header, 1))
            monkeypatch.setattr(GzipChunkEncoder, "encode", lambda encoder, array: 1 / 0)
            writer.write_frame(make_frame(header, 2))
            monkeypatch.setattr(GzipChunkEncoder, "encode", encode)
            writer.commit()
    assert writer.kept == (out_dir / "shot.partial.h5", 1) and not (out_dir / "shot.h5").exists()


@pytest.mark.parametrize(("dtype", "shape"), [(np.float32, (2, 3)), (np.float64, ()), (np.float64, (4, 4))])
def test_series_chunks_store_what_hdf5s_row_writes_store(tmp_path, dtype, shape):
    """Row by row over several 64-frame chunks (extents, stats, transforms): the same chunks,
    bytes and values as HDF5 writing each row itself."""
    rows = np.random.default_rng(2).normal(size=(150, *shape)).astype(dtype)
    with create_hdf5(tmp_path / "series.h5") as f:
        ours, theirs = (
            f.create_dataset(name, shape=(0, *shape), maxshape=(None, *shape), dtype=dtype, chunks=(64, *shape))
            for name in ("ours", "theirs")
        )
        series = SeriesChunks(ours)
        for k, row in enumerate(rows):
            series.write(k, row)
            theirs.resize(k + 1, axis=0)
            theirs[k] = row
            assert ours.shape == theirs.shape == (k + 1, *shape)
        for index in range(3):  # chunks of frames 0, 64 and 128 (the last one partly filled)
            assert ours.id.read_direct_chunk(ours.id.get_chunk_info(index).chunk_offset) == theirs.id.read_direct_chunk(
                theirs.id.get_chunk_info(index).chunk_offset
            )
        np.testing.assert_array_equal(ours[...], rows)


def test_series_chunks_refuse_rows_out_of_order(tmp_path):
    with create_hdf5(tmp_path / "series.h5") as f:
        series = SeriesChunks(f.create_dataset("s", shape=(0,), maxshape=(None,), dtype=np.float64, chunks=(4,)))
        for k in range(5):
            series.write(k, float(k))
        for k in (9, 6, 4):
            with pytest.raises(ValueError, match=rf"series row {k} written out of order \(the next row is 5\)"):
                series.write(k, float(k))
        assert f["s"].shape == (5,)
