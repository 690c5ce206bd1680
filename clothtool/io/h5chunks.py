"""Per-frame HDF5 chunks filtered by clothtool itself, then written as they are.

HDF5 compresses a chunk on the thread that writes it, holding the GIL, with zlib: at 128^2
that was 3.5x the simulation's time per frame. Here the chunk goes through the same filter
pipeline the dataset declares (shuffle, then deflate) in clothtool: the shuffle in numpy, the
deflate with ISA-L (``isal``: zlib-format streams some 7x faster than zlib at level 1, and
it releases the GIL, so a worker thread compresses while the solver runs). The bytes are
then written with ``write_direct_chunk`` and filter mask 0 ("every declared filter
applied"), so any HDF5 reader inflates them through its own shuffle+deflate filters. The
deflate stream differs from zlib's, but the same input always gives the same bytes.

    data = encode_chunk(points, "gzip")                  # any thread: numpy + isal only
    write_chunk(dataset, k, data)                         # the h5py thread
"""

from __future__ import annotations

import numpy as np
from isal import isal_zlib

# Compressions whose per-frame chunks clothtool encodes itself (lzf stays with h5py's filter).
ENCODED = ("gzip", "none")
# ISA-L's level 1: zlib level 1's ratio on float meshes (within a few %), at a seventh of the time.
DEFLATE_LEVEL = 1


def shuffle(array: np.ndarray) -> bytes:
    """HDF5's shuffle filter: the k-th byte of every element together, for each k in turn."""
    array = np.ascontiguousarray(array)
    return array.view(np.uint8).reshape(-1, array.dtype.itemsize).T.tobytes()


def snapshot(array: np.ndarray, compression: str) -> bytes:
    """The chunk's bytes before deflate (a copy: the caller may change ``array`` next)."""
    return shuffle(array) if compression == "gzip" else np.ascontiguousarray(array).tobytes()


def deflate(data: bytes, compression: str) -> bytes:
    """The stored chunk for ``snapshot``'s bytes; thread-safe (no h5py), releases the GIL."""
    return isal_zlib.compress(data, DEFLATE_LEVEL) if compression == "gzip" else data


def encode_chunk(array: np.ndarray, compression: str) -> bytes:
    """The bytes HDF5 stores for ``array`` as one chunk under ``compression``'s filters."""
    return deflate(snapshot(array, compression), compression)


def write_chunk(dataset, k: int, data: bytes) -> None:
    """Grow a per-frame dataset (chunks of one frame) to ``k + 1`` frames and store frame
    ``k``'s encoded chunk; raises OSError where HDF5 fails (a full disk)."""
    dataset.resize(k + 1, axis=0)
    dataset.id.write_direct_chunk((k,) + (0,) * (dataset.ndim - 1), data, filter_mask=0)
