"""Reference for clothtool.io.extent_kernel: the per-column min and max of (n,3) points, with numpy."""

from __future__ import annotations

import numpy as np


def points_box(points):
    """Returns f32 (2,3): row 0 the minimum, row 1 the maximum of each column (NaN where the column has one)."""
    points = np.asarray(points)
    return np.stack([points.min(axis=0), points.max(axis=0)]).astype(np.float32)


def _key(bits):
    """int32 keys ordering like the float32s whose bits (int32) ``bits`` are."""
    bits = np.asarray(bits, np.int32)
    return bits ^ ((bits >> 31) & np.int32(0x7FFFFFFF))
