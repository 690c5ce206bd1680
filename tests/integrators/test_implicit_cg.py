"""The filtered, block-Jacobi preconditioned CG and its helpers against
tests/reference/implicit_cg.py (scipy)."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.integrators.implicit.kernels.implicit_cg import CHUNKS, block_jacobi, block_matvec, filtered_pcg
from clothtool.integrators.implicit.pattern import build_pattern
from clothtool.integrators.implicit.rest import build_rest_shape
from tests.integrators.test_implicit_setup import grid_fabric
from tests.reference import implicit_cg as ref


def random_spd_system(rng, columns=7, pinned_fraction=0.2):
    """A random SPD matrix on a grid cloth's pattern: M + sum of element J^T J terms, so it
    is SPD with the cloth's sparsity; a random right-hand side and pinned particles."""
    fabric = grid_fabric(columns)
    shape = build_rest_shape(fabric.rest_pos, fabric.triangles)
    n = fabric.particle_count
    pattern = build_pattern(n, shape.triangles, shape.hinges)
    values = pattern.empty_values()
    for elements, slots in ((shape.triangles, pattern.triangle_slot), (shape.hinges, pattern.hinge_slot)):
        corners = elements.shape[1]
        for e in range(elements.shape[0]):
            j = rng.normal(size=(2, 3 * corners))
            local = 50.0 * j.T @ j  # stiff coupling, as h^2 k dwarfs the masses
            for a in range(corners):
                for b in range(corners):
                    values[slots[e, a * corners + b]] += local[3 * a:3 * a + 3, 3 * b:3 * b + 3]
    for k in range(3):
        values[pattern.diagonal_slot, k, k] += rng.uniform(0.5, 2.0, n)
    free = (rng.random(n) >= pinned_fraction).astype(np.uint8)
    rhs = rng.normal(size=(n, 3))
    return pattern, values, free, rhs


def solve(pattern, values, free, rhs, tolerance, max_iterations, absolute=0.0):
    n = rhs.shape[0]
    inverse = np.zeros((n, 3, 3))
    block_jacobi(pattern.diagonal_slot, values, free, inverse)
    dv = np.full((n, 3), np.nan)  # the solver must overwrite every entry
    scratch = [np.zeros((n, 3)) for _ in range(4)]
    iterations, residual = filtered_pcg(pattern.row_offsets, pattern.columns, values, inverse, free, rhs, tolerance,
                                        absolute, max_iterations, dv, *scratch, np.zeros((CHUNKS, 2)))
    return dv, iterations, residual


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cg_converges_to_the_filtered_solution(seed):
    rng = np.random.default_rng(seed)
    pattern, values, free, rhs = random_spd_system(rng)
    dv, iterations, residual = solve(pattern, values, free, rhs, 1e-10, 1000)
    expected = ref.filtered_pcg(pattern.row_offsets, pattern.columns, values, free, rhs)
    assert residual <= 1e-10 and 0 < iterations < 1000
    # the reported residual is the true one
    matrix = ref.to_scipy(pattern.row_offsets, pattern.columns, values)
    mask = np.repeat(free != 0, 3)
    r = (rhs.reshape(-1) - matrix @ dv.reshape(-1))[mask]
    assert np.linalg.norm(r) / np.linalg.norm(rhs.reshape(-1)[mask]) == pytest.approx(residual, rel=1e-3, abs=1e-13)
    np.testing.assert_allclose(dv, expected, rtol=0, atol=1e-7 * np.abs(expected).max())
    # filtered (pinned) rows stay exactly zero
    assert np.all(dv[free == 0] == 0.0)


def test_cg_stops_at_the_tolerance_or_the_cap():
    rng = np.random.default_rng(3)
    pattern, values, free, rhs = random_spd_system(rng)
    _, loose_iterations, loose = solve(pattern, values, free, rhs, 1e-3, 1000)
    _, tight_iterations, tight = solve(pattern, values, free, rhs, 1e-9, 1000)
    assert loose <= 1e-3 and tight <= 1e-9
    assert loose_iterations < tight_iterations
    dv, capped_iterations, capped = solve(pattern, values, free, rhs, 1e-12, 5)
    assert capped_iterations == 5 and capped > 1e-12 and np.all(dv[free == 0] == 0.0)


def test_cg_with_zero_rhs_does_nothing():
    rng = np.random.default_rng(4)
    pattern, values, free, rhs = random_spd_system(rng)
    dv, iterations, residual = solve(pattern, values, free, np.zeros_like(rhs), 1e-6, 100)
    assert iterations == 0 and residual == 0.0 and np.all(dv == 0.0)


def test_cg_absolute_floor_skips_a_rounding_sized_rhs():
    """A right-hand side that is zero but for rounding costs no iterations, and the reported
    residual is relative to the floor (absolute / tolerance)."""
    rng = np.random.default_rng(6)
    pattern, values, free, rhs = random_spd_system(rng)
    tiny = rhs * 1e-15
    _, iterations, residual = solve(pattern, values, free, tiny, 1e-6, 100, absolute=1e-12)
    assert iterations == 0 and residual < 1e-6
    _, iterations, _ = solve(pattern, values, free, rhs, 1e-6, 1000, absolute=1e-12)
    assert iterations > 5  # a real right-hand side is solved as before


def test_block_matvec_and_jacobi_match_scipy():
    rng = np.random.default_rng(5)
    pattern, values, free, _ = random_spd_system(rng)
    vector = rng.normal(size=(pattern.row_offsets.shape[0] - 1, 3))
    out = np.zeros_like(vector)
    block_matvec(pattern.row_offsets, pattern.columns, values, vector, out)
    np.testing.assert_allclose(out, ref.block_matvec(pattern.row_offsets, pattern.columns, values, vector), rtol=1e-13, atol=1e-12)
    inverse = np.zeros((vector.shape[0], 3, 3))
    block_jacobi(pattern.diagonal_slot, values, free, inverse)
    np.testing.assert_allclose(inverse, ref.block_jacobi(pattern.diagonal_slot, values, free), rtol=1e-12, atol=1e-15)
