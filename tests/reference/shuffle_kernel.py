"""Reference for clothtool.io.shuffle_kernel: HDF5's shuffle of 4-byte words, with numpy."""

from __future__ import annotations

import numpy as np


def shuffle_words(words, planes=None):
    """Returns u8 (4, n): row k holds byte k (little-endian) of every word."""
    return np.ascontiguousarray(np.asarray(words, "<u4").view(np.uint8).reshape(-1, 4).T)
