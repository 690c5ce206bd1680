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
