"""HDF5's shuffle filter for 4-byte elements (float32) as a compiled loop.

numpy transposes an (n, 4) byte matrix through its strided-copy loop: ~55 us for a 128^2
cloth's points, twice a frame (points and velocities). This loop takes ~5 us (a loop over a
run-time element size, 4 at run time, took 110 us: the four stores per element must be
spelled out for LLVM to vectorise them). Imported on the first compressed chunk only (numba
loads with it), never by readers.
"""

from __future__ import annotations

from clothtool._jit import kernel


@kernel
def shuffle_words(words, planes):
    """planes[k, i] = byte k (little-endian) of words[i], for 32-bit ``words`` and (4, n) u8 ``planes``."""
    for i in range(words.shape[0]):
        word = words[i]
        planes[0, i] = word & 0xFF
        planes[1, i] = (word >> 8) & 0xFF
        planes[2, i] = (word >> 16) & 0xFF
        planes[3, i] = word >> 24
