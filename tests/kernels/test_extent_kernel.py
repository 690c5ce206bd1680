"""points_box (the per-frame extent the cache writers store) against tests/reference/extent_kernel.py."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clothtool.io.cache_common import points_extent
from clothtool.io.extent_kernel import frame_extent, points_box
from tests.reference import extent_kernel as ref


@settings(max_examples=25)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 2000))
def test_points_box_matches_reference(seed, n):
    points = np.random.default_rng(seed).normal(0.0, 10.0, (n, 3)).astype(np.float32)
    box = np.full((2, 3), 7.0, np.float32)
    points_box(points, box)
    np.testing.assert_array_equal(box, ref.points_box(points))
    np.testing.assert_array_equal(frame_extent(points), points_extent(points))  # what the readers compute


def test_box_by_hand():
    points = np.array([[1.0, -2.0, 3.0], [-4.0, 5.0, 3.0], [0.5, 0.0, -6.0]], np.float32)
    np.testing.assert_array_equal(frame_extent(points), [[-4.0, -2.0, -6.0], [1.0, 5.0, 3.0]])


@pytest.mark.parametrize("row", [0, 1, 36])
def test_a_nan_makes_its_column_nan_as_numpy_does(row):
    points = np.random.default_rng(row).normal(size=(37, 3)).astype(np.float32)
    points[row, 1] = np.nan
    box = frame_extent(points)
    np.testing.assert_array_equal(box, ref.points_box(points))
    assert np.isnan(box[:, 1]).all() and np.isfinite(box[:, [0, 2]]).all()


def test_infinities_are_kept():
    points = np.array([[np.inf, 0.0, -np.inf], [1.0, 2.0, 3.0]], np.float32)
    np.testing.assert_array_equal(frame_extent(points), [[1.0, 0.0, -np.inf], [np.inf, 2.0, 3.0]])


@pytest.mark.parametrize("bits", [0x7FC00000, 0xFFC00000, 0x7F800001, 0xFFFFFFFF])
def test_a_nan_of_either_sign_and_any_payload_makes_its_column_nan(bits):
    """The integer keys put every NaN outside -inf..+inf, whatever its sign bit and payload."""
    points = np.array([[1.0, np.inf, -2.0], [3.0, -np.inf, 4.0]], np.float32)
    points.view(np.uint32)[1, 2] = bits
    box = frame_extent(points)
    assert np.isnan(box[:, 2]).all()
    np.testing.assert_array_equal(box[:, :2], [[1.0, -np.inf], [3.0, np.inf]])


def test_signed_zeros_and_tiny_values_order_as_floats():
    points = np.array([[0.0, -1e-45, 2.0], [-0.0, 1e-45, -2.0], [0.0, 0.0, -3.0]], np.float32)
    box = frame_extent(points)
    np.testing.assert_array_equal(box, np.array([[0.0, -1e-45, -3.0], [0.0, 1e-45, 2.0]], np.float32))
    assert np.signbit(box[0, 0]) and not np.signbit(box[1, 0])  # -0.0 is the min, +0.0 the max


def test_an_empty_array_gives_an_inverted_infinite_box():
    np.testing.assert_array_equal(frame_extent(np.zeros((0, 3), np.float32)), [[np.inf] * 3, [-np.inf] * 3])
