"""Phase classification: closed-form counts on grids, hang direction, quad recovery."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.fabric import PhaseType
from clothtool.mesh.shapes import grid


def phase_counts(fabric) -> dict[str, int]:
    counts = {}
    for i in range(fabric.phase_count):
        span = fabric.phase_constraints(i)
        counts[PhaseType(int(fabric.phase_type[i])).label] = span.stop - span.start
    return counts


@pytest.mark.parametrize("n", [2, 3, 5, 12])
@pytest.mark.parametrize("quads", [False, True])
def test_grid_phase_counts_match_closed_forms(n, quads):
    fabric = cook_fabric(grid(n, n, 0.1, quads=quads), CookOptions(tethers="none")).fabric
    counts = phase_counts(fabric)
    assert counts["vertical"] == n * (n - 1)
    assert counts["horizontal"] == n * (n - 1)
    assert counts["shearing"] == 2 * (n - 1) ** 2
    assert counts.get("bending", 0) == 2 * n * (n - 2)


def test_rectangular_grid_counts_and_rest_lengths():
    cols, rows, h = 7, 4, 0.05
    fabric = cook_fabric(grid(cols, rows, h), CookOptions(tethers="none")).fabric
    counts = phase_counts(fabric)
    assert counts["vertical"] == cols * (rows - 1)
    assert counts["horizontal"] == rows * (cols - 1)
    assert counts["shearing"] == 2 * (cols - 1) * (rows - 1)
    assert counts["bending"] == rows * (cols - 2) + cols * (rows - 2)
    expected_length = {1: h, 2: h, 4: h * np.sqrt(2), 3: 2 * h}
    for i in range(fabric.phase_count):
        lengths = fabric.constraint_rest_length[fabric.phase_constraints(i)]
        np.testing.assert_allclose(lengths, expected_length[int(fabric.phase_type[i])], rtol=1e-6)


def test_vertical_edges_follow_the_hang_direction():
    mesh = grid(6, 3, 0.1)  # columns along X, rows down -Y
    default = cook_fabric(mesh, CookOptions(tethers="none")).fabric
    sideways = cook_fabric(mesh, CookOptions(tethers="none", hang_direction=(1.0, 0.0, 0.0))).fabric
    p = default.rest_pos
    for fabric, axis in ((default, 1), (sideways, 0)):
        span = fabric.phase_constraints(list(fabric.phase_type).index(PhaseType.VERTICAL))
        pairs = fabric.constraint_indices[span]
        d = np.abs(p[pairs[:, 1]] - p[pairs[:, 0]])
        assert np.all(d[:, axis] > 0) and np.all(d[:, 1 - axis] == 0)
    assert phase_counts(default)["vertical"] == phase_counts(sideways)["horizontal"]


def test_no_quad_recovery_makes_the_triangulation_diagonal_a_stretch_edge():
    n = 5
    fabric = cook_fabric(grid(n, n, 0.1), CookOptions(tethers="none", recover_quads=False)).fabric
    counts = phase_counts(fabric)
    assert "shearing" not in counts
    assert counts["vertical"] + counts["horizontal"] == 2 * n * (n - 1) + (n - 1) ** 2


def test_phases_can_be_switched_off():
    fabric = cook_fabric(grid(4, 4, 0.1), CookOptions(tethers="none", bending=False, shearing=False)).fabric
    assert set(phase_counts(fabric)) == {"vertical", "horizontal"}


def test_bending_pairs_are_two_collinear_edges_apart():
    fabric = cook_fabric(grid(6, 6, 0.1), CookOptions(tethers="none")).fabric
    span = fabric.phase_constraints(list(fabric.phase_type).index(PhaseType.BENDING))
    pairs = fabric.constraint_indices[span]
    d = fabric.rest_pos[pairs[:, 1]] - fabric.rest_pos[pairs[:, 0]]
    # every bending pair spans two grid cells along a row or a column
    assert np.allclose(np.sort(np.abs(d[:, :2]), axis=1), [0.0, 0.2], atol=1e-6)
