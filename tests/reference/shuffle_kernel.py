"""Reference for clothtool.io.shuffle_kernel: HDF5's shuffle of 4-byte words, with numpy."""

from __future__ import annotations

import numpy as np


def shuffle_words(words, planes=None):
    """Returns u8 (4, n): row k holds byte k (little-endian) of every word."""
    return np.ascontiguousarray(np.asarray(words, "<u4").view(np.uint8).reshape(-1, 4).T)


def shuffle_into_stream(words, runs, stream, last):
    """Fills ``stream`` and ``last`` as the kernel does: for each run (j0, j1, at0, at1, at2)
    byte k of words[j0:j1] at stream[atk:], byte 3 into last[j0:j1]."""
    planes = shuffle_words(words)
    for j0, j1, *ats in np.asarray(runs):
        for k, at in enumerate(ats):
            stream[at : at + j1 - j0] = planes[k, j0:j1]
    last[:] = planes[3]
