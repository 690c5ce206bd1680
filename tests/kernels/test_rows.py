"""copy_xyz / xyz_velocity against tests/reference/rows.py."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.solver.kernels.rows import copy_xyz, xyz_velocity
from tests.kernels._data import particles
from tests.reference import rows as ref


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("n", [0, 1, 37])
def test_copy_xyz_matches_reference(n, dtype):
    cur, _ = particles(np.random.default_rng(n), n)
    cur = cur.astype(dtype)
    out = np.full((n, 3), np.nan, dtype)
    copy_xyz(cur, out)
    np.testing.assert_array_equal(out, ref.copy_xyz(cur, out))


@pytest.mark.parametrize("n", [0, 1, 37])
def test_xyz_velocity_matches_reference(n):
    cur, prev = particles(np.random.default_rng(100 + n), n)
    h = np.float32(1.0 / 300.0)
    out = np.full((n, 3), np.nan, np.float32)
    xyz_velocity(cur, prev, h, out)
    # the same float32 operations in the same order: equal bit for bit
    np.testing.assert_array_equal(out, ref.xyz_velocity(cur, prev, h, out))
    assert np.abs(out).max(initial=1.0) > 0.1  # speeds of ~0.02 / (1/300)
