"""shuffle_words and shuffle_into_stream (the gzip chunks' shuffle) against tests/reference/shuffle_kernel.py."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from clothtool.io.shuffle_kernel import shuffle_into_stream, shuffle_words
from tests.reference import shuffle_kernel as ref


@settings(max_examples=20)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 3000))
def test_shuffle_words_matches_reference(seed, n):
    words = np.random.default_rng(seed).integers(0, 2**32, n, dtype=np.uint64).astype(np.uint32)
    planes = np.full((4, n), 7, np.uint8)
    shuffle_words(words, planes)
    np.testing.assert_array_equal(planes, ref.shuffle_words(words))


def test_byte_order_by_hand():
    planes = np.zeros((4, 2), np.uint8)
    shuffle_words(np.array([0x04030201, 0xA0B0C0D0], np.uint32), planes)
    np.testing.assert_array_equal(planes, [[0x01, 0xD0], [0x02, 0xC0], [0x03, 0xB0], [0x04, 0xA0]])


@settings(max_examples=20)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 500), cuts=st.integers(0, 4))
def test_shuffle_into_stream_matches_reference(seed, n, cuts):
    """Runs of words cut anywhere, their three low bytes placed at scattered offsets."""
    rng = np.random.default_rng(seed)
    words = rng.integers(0, 2**32, n, dtype=np.uint64).astype(np.uint32)
    bounds = sorted({0, n, *rng.integers(1, n, cuts).tolist()} if n > 1 else {0, n})
    runs, at = [], 7
    for j0, j1 in zip(bounds, bounds[1:]):
        runs.append((j0, j1, at, at + 3 * n + 5, at + 6 * n + 11))
        at += j1 - j0
    runs = np.array(runs, np.int64).reshape(-1, 5)
    ours, theirs = np.zeros(9 * n + 20, np.uint8), np.zeros(9 * n + 20, np.uint8)
    last, last_ref = np.empty(n, np.uint8), np.empty(n, np.uint8)
    shuffle_into_stream(words, runs, ours, last)
    ref.shuffle_into_stream(words, runs, theirs, last_ref)
    np.testing.assert_array_equal(ours, theirs)
    np.testing.assert_array_equal(last, last_ref)
