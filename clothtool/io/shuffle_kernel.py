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



@kernel
def shuffle_into_stream(words, runs, stream, last):
    """HDF5's shuffle of 32-bit ``words`` written where a gzip chunk's zlib stream holds it:
    each row (j0, j1, at0, at1, at2) of ``runs`` puts byte k (k = 0, 1, 2) of words[j0:j1]
    at stream[atk:atk + j1 - j0] (inside the stored blocks of planes 0-2) and byte 3 at
    last[j0:j1] (the plane deflate takes). The runs are cut where a stored block's header
    interrupts a plane. Each run goes through slices: indexing ``stream`` with a computed
    offset makes numba check it for wrap-around and stops LLVM vectorising (4x slower)."""
    for r in range(runs.shape[0]):
        j0, j1 = runs[r, 0], runs[r, 1]
        n = j1 - j0
        source = words[j0:j1]
        plane0 = stream[runs[r, 2] : runs[r, 2] + n]
        plane1 = stream[runs[r, 3] : runs[r, 3] + n]
        plane2 = stream[runs[r, 4] : runs[r, 4] + n]
        plane3 = last[j0:j1]
        for j in range(n):
            word = source[j]
            plane0[j] = word & 0xFF
            plane1[j] = (word >> 8) & 0xFF
            plane2[j] = (word >> 16) & 0xFF
            plane3[j] = word >> 24
