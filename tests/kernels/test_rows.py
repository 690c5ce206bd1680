"""copy_xyz / xyz_velocity / gather_xyz against tests/reference/rows.py."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.solver.kernels.rows import copy_xyz, gather_xyz, vertex_rows, xyz_velocity
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


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("n", [0, 1, 37, 64, 65, 200])
def test_xyz_velocity_matches_reference(n, dtype):
    """Within one block of 64 rows and across blocks (a last one full or partial), in
    either state precision (h in the state's)."""
    cur, prev = particles(np.random.default_rng(100 + n), n)
    cur, prev = cur.astype(dtype), prev.astype(dtype)
    h = dtype(1.0 / 300.0)
    out = np.full((n, 3), np.nan, np.float32)
    xyz_velocity(cur, prev, h, out)
    # the same operations in h's precision, one rounding to float32: equal bit for bit
    np.testing.assert_array_equal(out, ref.xyz_velocity(cur, prev, h, out))
    assert np.abs(out).max(initial=1.0) > 0.1  # speeds of ~0.02 / (1/300)


@pytest.mark.parametrize("rows_dtype", [np.float32, np.float64])
@pytest.mark.parametrize("n", [0, 1, 37])
@pytest.mark.parametrize("width", [3, 4])
def test_gather_xyz_matches_reference(n, rows_dtype, width):
    """Particle rows (x, y, z[, w]) of either precision into vertex order, as float32."""
    rng = np.random.default_rng(200 + n)
    cur, _ = particles(rng, n)
    rows = np.ascontiguousarray(cur[:, :width], rows_dtype) + rows_dtype(1e-9)  # float64 digits float32 rounds
    order = rng.permutation(n).astype(np.int64)
    out = np.full((n, 3), np.nan, np.float32)
    gather_xyz(rows, order, out)
    np.testing.assert_array_equal(out, ref.gather_xyz(rows, order, out))


def test_gather_xyz_by_hand():
    rows = np.array([[0.0, 1.0, 2.0, 9.0], [3.0, 4.0, 5.0, 9.0], [6.0, 7.0, 8.0, 9.0]])
    out = np.zeros((3, 3), np.float32)
    gather_xyz(rows, np.array([2, 0, 1]), out)
    np.testing.assert_array_equal(out, [[6, 7, 8], [0, 1, 2], [3, 4, 5]])


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("n, vertices", [(0, 0), (1, 1), (63, 63), (64, 64), (65, 80), (200, 150)])
def test_vertex_rows_are_the_gathered_copy_and_velocity(n, vertices, dtype):
    """The one-pass rows have the bits of gather_xyz over copy_xyz's and xyz_velocity's
    (the kernels a bake used before), and match the reference; vertices may share a particle
    (a seam) or leave one out."""
    rng = np.random.default_rng(300 + n)
    cur, prev = particles(rng, n, speed=0.05)
    cur, prev = cur.astype(dtype) + dtype(1e-9), prev.astype(dtype)
    order = rng.integers(0, max(n, 1), vertices).astype(np.int64)
    h = dtype(1.0 / 240.0)
    points, velocities = np.full((vertices, 3), np.nan, np.float32), np.full((vertices, 3), np.nan, np.float32)
    vertex_rows(cur, prev, order, h, points, velocities)
    copied, moved = np.empty((n, 3), dtype), np.empty((n, 3), np.float32)
    copy_xyz(cur, copied)
    xyz_velocity(cur, prev, h, moved)
    want_points, want_velocities = np.empty_like(points), np.empty_like(velocities)
    gather_xyz(copied, order, want_points)
    gather_xyz(moved, order, want_velocities)
    np.testing.assert_array_equal(points, want_points)
    np.testing.assert_array_equal(velocities, want_velocities)
    ref_points, ref_velocities = ref.vertex_rows(cur, prev, order, h, points, velocities)
    np.testing.assert_array_equal(points, ref_points)
    np.testing.assert_array_equal(velocities, ref_velocities)
