"""The bounding box of a frame's points as a compiled loop (what caches store per frame).

numpy reduces an (n, 3) float32 array column by column through a transposed copy: ~45 us a
frame for a 128^2 cloth inside a bake. This loop reads the points once (~10 us). Like
numpy's ``min``/``max`` a NaN in a column makes that column's min and max NaN. Imported by
the cache writers only (numba loads with it), never by readers.
"""

from __future__ import annotations

from clothtool._jit import kernel


@kernel
def points_box(points, box):
    """box[0] = per-column minimum, box[1] = per-column maximum of (n, 3) ``points``; a column
    holding a NaN gets NaN in both rows; an empty array gives +inf / -inf."""
    lo0 = lo1 = lo2 = box.dtype.type(float("inf"))
    hi0 = hi1 = hi2 = box.dtype.type(float("-inf"))
    nan0 = nan1 = nan2 = False
    for i in range(points.shape[0]):
        x, y, z = points[i, 0], points[i, 1], points[i, 2]
        lo0 = x if x < lo0 else lo0
        hi0 = x if x > hi0 else hi0
        lo1 = y if y < lo1 else lo1
        hi1 = y if y > hi1 else hi1
        lo2 = z if z < lo2 else lo2
        hi2 = z if z > hi2 else hi2
        nan0 |= x != x
        nan1 |= y != y
        nan2 |= z != z
    box[0, 0], box[0, 1], box[0, 2] = lo0, lo1, lo2
    box[1, 0], box[1, 1], box[1, 2] = hi0, hi1, hi2
    nan = box.dtype.type(float("nan"))
    if nan0:
        box[0, 0] = box[1, 0] = nan
    if nan1:
        box[0, 1] = box[1, 1] = nan
    if nan2:
        box[0, 2] = box[1, 2] = nan


def frame_extent(points):
    """f32 (2,3): the bounding box (min row, max row) of (n,3) float32 ``points``, as
    ``clothtool.io.cache_common.points_extent`` gives it."""
    import numpy as np

    box = np.empty((2, 3), np.float32)
    points_box(points, box)
    return box
