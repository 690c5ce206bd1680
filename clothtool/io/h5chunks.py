"""Per-frame HDF5 chunks filtered by clothtool itself, then written as they are.

HDF5 compresses a chunk on the thread that writes it, holding the GIL, with zlib: at 128^2
that was 3.5x the simulation's time per frame. Here the chunk goes through the same filter
pipeline the dataset declares (shuffle, then deflate) in clothtool, and the bytes are written
with ``write_direct_chunk`` and filter mask 0 ("every declared filter applied"), so any HDF5
reader inflates them through its own shuffle+deflate filters.

The shuffle puts byte k of every float32 together, k = 0..3 (a compiled loop). Only the last
plane, the sign and exponent bits, is deflated (ISA-L via ``isal``): the three mantissa planes
of a moving cloth are noise that deflate shrinks by 0-3% (the bundled skirt's points and
velocities) at 20x the cost of the exponent plane, so they go into deflate's "stored" blocks
(RFC 1951 3.2.4: a length and the bytes as they are). The chunk is one zlib stream (RFC 1950):
header, stored blocks, the deflated exponent plane (its final block), the Adler-32 of the whole
shuffled chunk. The same input always gives the same bytes. A 128^2 cloth's chunk encodes in
~0.025 ms (deflating all four planes took ~0.45 ms): the Adler-32 is ~11 us of it, the
exponent plane's deflate ~7 us and the shuffle ~5 us. A cloth with one coordinate constant
(a flat sheet swinging in its plane) gives up more, its constant zeros being compressible
(the benchmark sheet: 77% of the raw size instead of 60%).

The writer encodes each per-frame dataset's chunks with a ``GzipChunkEncoder``, which
builds the stream in one buffer kept from frame to frame; ``encode_chunk`` gives the same
bytes for any array (the reference the encoder is tested against).

    encoder = GzipChunkEncoder(points.size)              # numpy + isal only, no h5py
    FrameChunks(dataset).write(k, encoder.encode(points))
"""

from __future__ import annotations

import struct
import sys

import numpy as np
from isal import isal_zlib

# Compressions whose per-frame chunks clothtool encodes itself (lzf stays with h5py's filter).
ENCODED = ("gzip", "none")
# ISA-L's level 1 for the exponent plane: zlib level 1's ratio, at a seventh of the time.
DEFLATE_LEVEL = 1
# zlib header: deflate with a 32 KiB window, "fastest" level flag, check bits (0x7801 % 31 == 0).
_ZLIB_HEADER = b"\x78\x01"
_STORED_BLOCK = 65535  # the most bytes one stored block holds


def shuffle(array: np.ndarray) -> np.ndarray:
    """HDF5's shuffle filter: u8 (itemsize, n), row k holding byte k of each of the n elements
    (its bytes are the filter's output). A copy: the caller may change ``array`` next."""
    array = np.ascontiguousarray(array)
    if array.dtype.itemsize != 4 or not _little_endian(array.dtype):  # not float32 points: numpy's transpose
        return np.ascontiguousarray(array.reshape(-1).view(np.uint8).reshape(-1, array.dtype.itemsize).T)
    from clothtool.io.shuffle_kernel import shuffle_words

    planes = np.empty((4, array.size), np.uint8)
    shuffle_words(array.reshape(-1).view(np.uint32), planes)
    return planes


def _little_endian(dtype: np.dtype) -> bool:
    return dtype.byteorder == "<" or (dtype.byteorder in "=|" and sys.byteorder == "little")


def snapshot(array: np.ndarray, compression: str):
    """The chunk's bytes before deflate, as ``deflate`` takes them (a copy: the caller may
    change ``array`` next): for gzip the shuffled byte planes."""
    return shuffle(array) if compression == "gzip" else np.ascontiguousarray(array).tobytes()


def deflate(data, compression: str) -> bytes:
    """The stored chunk for ``snapshot``'s bytes; thread-safe (no h5py), releases the GIL."""
    return zlib_stream(data) if compression == "gzip" else data


def zlib_stream(planes: np.ndarray) -> bytes:
    """The zlib stream of ``planes``' bytes (u8 (itemsize, n), C order): every plane but the
    last as stored blocks, the last (the most significant byte of little-endian floats)
    deflated."""
    flat = planes.reshape(-1).data
    split = (planes.shape[0] - 1) * planes.shape[1]
    parts: list[bytes | memoryview] = [_ZLIB_HEADER]
    for start in range(0, split, _STORED_BLOCK):
        block = flat[start : min(start + _STORED_BLOCK, split)]
        # BFINAL 0, BTYPE 00 (stored), padded to the byte; then LEN and its complement NLEN.
        parts += [struct.pack("<BHH", 0, len(block), len(block) ^ 0xFFFF), block]
    # a stream, not isal's one-shot compress: that gives other bytes for small planes, and
    # files from the same bake stay the same bytes as before
    deflater = isal_zlib.compressobj(DEFLATE_LEVEL, isal_zlib.DEFLATED, -isal_zlib.MAX_WBITS)  # raw deflate
    parts += [deflater.compress(flat[split:]), deflater.flush(), struct.pack(">I", isal_zlib.adler32(flat))]
    return b"".join(parts)


def encode_chunk(array: np.ndarray, compression: str) -> bytes:
    """The bytes HDF5 stores for ``array`` as one chunk under ``compression``'s filters."""
    return deflate(snapshot(array, compression), compression)


class GzipChunkEncoder:
    """``encode_chunk(array, "gzip")`` for the float32 chunks of one per-frame dataset, into
    one buffer kept from frame to frame: the stream's header and its stored blocks' headers
    depend only on the chunk's size, so they are written once, and the shuffle puts each
    frame's mantissa planes straight into the stored blocks (no planes array, no joining
    of the parts: ~0.02 ms less a 128^2 chunk). ``encode`` returns a view of that buffer,
    valid until the next ``encode``: the caller writes it before encoding this dataset's
    next chunk. Byte for byte what ``encode_chunk`` gives (tested)."""

    def __init__(self, elements: int):
        """``elements``: the 4-byte values in a chunk (3 per point)."""
        self.elements = elements
        split = 3 * elements  # the stored planes' bytes
        payloads, headers, at = [], [], len(_ZLIB_HEADER)
        for start in range(0, split, _STORED_BLOCK):
            end = min(start + _STORED_BLOCK, split)
            headers.append((at, struct.pack("<BHH", 0, end - start, (end - start) ^ 0xFFFF)))
            payloads.append((at + 5, at + 5 + end - start, start))
            at += 5 + end - start

        def stream_offset(position: int) -> int:  # of byte ``position`` of the planes' concatenation
            block = position // _STORED_BLOCK
            return payloads[block][0] + position - payloads[block][2]

        # Runs of words whose three stored bytes each land in one stored block.
        block_starts = [start for _, _, start in payloads]
        cuts = sorted({0, elements} | {b - k * elements for b in block_starts for k in range(3) if 0 < b - k * elements < elements})
        self._runs = np.array(
            [(j0, j1, *(stream_offset(k * elements + j0) for k in range(3))) for j0, j1 in zip(cuts, cuts[1:])], np.int64
        ).reshape(-1, 5)
        self._deflated_at = at
        self._buffer = np.empty(at + self.deflated_room(elements) + 4, np.uint8)  # + Adler-32
        self._buffer[: len(_ZLIB_HEADER)] = np.frombuffer(_ZLIB_HEADER, np.uint8)
        for where, header in headers:
            self._buffer[where : where + 5] = np.frombuffer(header, np.uint8)
        self._view = self._buffer.data
        self._payload_ranges = [(start, end) for start, end, _ in payloads]
        self._payloads = [self._view[start:end] for start, end in self._payload_ranges]
        self._exponents = np.empty(elements, np.uint8)  # plane 3, deflate's input

    @staticmethod
    def deflated_room(elements: int) -> int:
        """Room kept for the deflated plane of ``elements`` bytes: ISA-L's level 1 output of
        random bytes is ~0.07% larger than its input; a plane that needs more grows the
        buffer."""
        return elements + elements // 64 + 256

    def encode(self, array: np.ndarray) -> memoryview:
        """The stored chunk of ``array`` (``elements`` float32 values, C-contiguous: what
        ``as_points`` gives), as a view of the buffer."""
        if array.dtype != np.float32 or array.size != self.elements or not array.flags.c_contiguous:
            raise ValueError(f"a chunk is {self.elements} contiguous float32 values, got {array.size} of {array.dtype}")
        if sys.byteorder != "little":  # the kernel reads words as the machine orders them
            return memoryview(encode_chunk(array, "gzip"))
        from clothtool.io.shuffle_kernel import shuffle_into_stream

        exponents, view = self._exponents, self._view
        shuffle_into_stream(array.reshape(-1).view(np.uint32), self._runs, self._buffer, exponents)
        deflater = isal_zlib.compressobj(DEFLATE_LEVEL, isal_zlib.DEFLATED, -isal_zlib.MAX_WBITS)  # as zlib_stream
        deflated = deflater.compress(exponents) + deflater.flush()
        check = 1  # Adler-32 of the shuffled bytes in stream order: the stored runs, then plane 3
        for payload in self._payloads:
            check = isal_zlib.adler32(payload, check)
        check = isal_zlib.adler32(exponents, check)
        start = self._deflated_at
        end = start + len(deflated)
        if end + 4 > len(view):  # more than deflated_room
            self._grow(end + 4)
            view = self._view
        view[start:end] = deflated
        view[end : end + 4] = check.to_bytes(4, "big")
        return view[: end + 4]

    def _grow(self, size: int) -> None:
        buffer = np.empty(size, np.uint8)
        buffer[: self._deflated_at] = self._buffer[: self._deflated_at]
        self._buffer, self._view = buffer, buffer.data
        self._payloads = [self._view[start:end] for start, end in self._payload_ranges]


class FrameChunks:
    """A per-frame dataset (chunks of one frame) written a stored chunk at a time. Its row
    shape is read once: h5py's ``DatasetID.shape`` asks HDF5 for the dataspace on every call
    (~10 us, as much as storing a 128^2 chunk's bytes takes in HDF5 itself)."""

    def __init__(self, dataset):
        self.dataset = dataset
        self._dsid = dataset.id
        self._tail = tuple(dataset.shape[1:])
        self._zeros = (0,) * len(self._tail)

    def write(self, k: int, data) -> None:
        """Grow the dataset to ``k + 1`` frames and store frame ``k``'s encoded chunk (bytes
        or a contiguous array); raises OSError where HDF5 fails (a full disk)."""
        self._dsid.set_extent((k + 1,) + self._tail)  # h5py's resize() costs 7x as much in checks
        self._dsid.write_direct_chunk((k,) + self._zeros, data, filter_mask=0)


class SeriesChunks:
    """A small per-frame series (unfiltered chunks of several frames: extents, stats,
    transforms) written a whole chunk at a time. The chunk being filled is kept here and
    stored again with each new row; HDF5's own row write reads the chunk back from the file
    first (clothtool's files have no chunk cache): 0.04 against 0.012 ms a row. Rows come
    in order from 0; rows not yet written are 0, HDF5's fill value, as they are when HDF5
    writes the row itself, so the file holds the same bytes."""

    def __init__(self, dataset):
        self._dsid = dataset.id
        self._chunk = np.zeros(dataset.chunks, dataset.dtype)
        self._first = 0  # the frame of the chunk's first row
        self._next = 0  # the frame the next row must be

    def write(self, k: int, value) -> None:
        """Grow the dataset to ``k + 1`` frames and store frame ``k``'s row; raises OSError
        where HDF5 fails (a full disk)."""
        if k != self._next:
            raise ValueError(f"series row {k} written out of order (the next row is {self._next})")
        rows = self._chunk.shape[0]
        if k == self._first + rows:  # the next chunk
            self._first = k
            self._chunk[...] = 0
        self._chunk[k - self._first] = value
        self._dsid.set_extent((k + 1,) + self._chunk.shape[1:])
        self._dsid.write_direct_chunk((self._first,) + (0,) * (self._chunk.ndim - 1), self._chunk, filter_mask=0)
        self._next = k + 1
