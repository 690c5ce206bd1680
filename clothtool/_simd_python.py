"""clothtool._simd's operations in plain Python on numpy 4-vectors, used in its place under
NUMBA_DISABLE_JIT=1 (where the kernels run as Python and numba intrinsics cannot be called).
Used so, CI's kernel tests check the kernels' own logic (indices, bounds) without numba."""

from __future__ import annotations

import numpy as np

__all__ = ["load4", "store4", "vadd", "vsub", "vmul", "fill", "lane", "keep_w", "transpose4", "w_lanes", "is_double"]


def load4(array, index):
    return array[index : index + 4].copy()


def store4(array, index, value):
    array[index : index + 4] = value


def vadd(a, b):
    return a + b


def vsub(a, b):
    return a - b


def vmul(a, b):
    return a * b


def fill(like, x):
    return np.full(4, x, like.dtype)


def lane(value, k):
    return value[k]


def keep_w(new, old):
    return np.array([new[0], new[1], new[2], old[3]], new.dtype)


def transpose4(r0, r1, r2, r3):
    rows = np.stack([r0, r1, r2, r3])
    return rows[:, 0].copy(), rows[:, 1].copy(), rows[:, 2].copy(), rows[:, 3].copy()


def w_lanes(r0, r1, r2, r3):
    return np.array([r0[3], r1[3], r2[3], r3[3]], r0.dtype)


def is_double(array):
    return array.dtype == np.float64
