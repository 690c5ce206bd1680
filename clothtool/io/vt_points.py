"""(n, 3) float32 numpy points into a ``Vt.Vec3fArray`` at memcpy speed (USD cache frames).

``Vt.Vec3fArray.FromNumpy`` converts its input one float at a time through a function
pointer: ~130 us for a 128^2 cloth's points, twice a frame (points and velocities), more
than the rest of a USD frame's writing. A new ``Vt.Vec3fArray(n)`` owns its storage alone
(nothing shares it until it is handed to the layer) and exports that storage through the
buffer protocol, read-only only to protect the arrays that share storage: copying the
points into it is a memcpy (~12 us with the allocation). Whether the export really is the
array's own storage is checked once per process on a small array; where it is not (another
USD build) the points go through ``FromNumpy``.
"""

from __future__ import annotations

import ctypes
import functools

import numpy as np

import clothtool.usd_env  # noqa: F401  (before pxr)

# isort: split
from pxr import Vt


def vec3f_array(points: np.ndarray) -> "Vt.Vec3fArray":
    """A new Vt.Vec3fArray holding (n, 3) ``points`` as float32 (rounded as FromNumpy rounds
    wider floats)."""
    points = np.ascontiguousarray(points, np.float32)
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"points must have shape (n, 3), got {points.shape}")
    if not _fills_in_place():
        return Vt.Vec3fArray.FromNumpy(points)
    return _filled(points)


def _filled(points: np.ndarray) -> "Vt.Vec3fArray":
    array = Vt.Vec3fArray(points.shape[0])
    if points.shape[0]:
        storage = np.asarray(array)  # a view of the new array's own storage (see the module docstring)
        ctypes.memmove(storage.ctypes.data, points.ctypes.data, points.nbytes)
    return array


@functools.cache
def _fills_in_place() -> bool:
    """Whether this USD build's Vt.Vec3fArray exports its own storage (a copy made into
    the export would be lost): checked by reading a filled array back through Vt."""
    probe = np.arange(6, dtype=np.float32).reshape(2, 3) + np.float32(0.5)
    try:
        array = _filled(probe)
    except (TypeError, ValueError, BufferError):
        return False
    return [tuple(array[i]) for i in range(2)] == [tuple(row) for row in probe.tolist()]
