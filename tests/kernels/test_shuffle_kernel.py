"""shuffle_words (the gzip chunks' shuffle) against tests/reference/shuffle_kernel.py."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from clothtool.io.shuffle_kernel import shuffle_words
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
