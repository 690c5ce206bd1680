"""HDF5's shuffle filter as a compiled loop.

numpy transposes an (n, 4) byte matrix through its strided-copy loop: ~55 us for a 128^2
cloth's points, twice a frame (points and velocities). This loop takes ~5 us. Imported on
the first compressed chunk only (numba loads with it), never by readers.
"""

from __future__ import annotations

from clothtool._jit import kernel


@kernel
def shuffle_bytes(source, planes):
    """planes[k, i] = source[i * size + k]: byte k of every ``size``-byte element together,
    for each k in turn, where ``planes`` is (size, n) and ``source`` the n elements' bytes."""
    size, count = planes.shape
    for i in range(count):
        for k in range(size):
            planes[k, i] = source[i * size + k]
