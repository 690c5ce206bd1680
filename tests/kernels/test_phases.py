"""clothtool.cook.phases._bending_pairs against tests/reference/phases.py."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clothtool.cook.adjacency import csr_from_pairs
from clothtool.cook.phases import BENDING_MIN_ANGLE_DEG, _bending_pairs
from clothtool.mesh.shapes import grid
from tests.reference import phases as ref

COS_LIMIT = np.cos(np.radians(BENDING_MIN_ANGLE_DEG))


def neighbours(edges, n):
    """Symmetric CSR adjacency, as build_phases makes it from the stretch edges."""
    rows = np.concatenate([edges[:, 0], edges[:, 1]])
    cols = np.concatenate([edges[:, 1], edges[:, 0]])
    order = np.lexsort((cols, rows))
    return csr_from_pairs(rows[order], cols[order], n)


def check(edges, pos, cos_limit=COS_LIMIT):
    offsets, flat = neighbours(np.asarray(edges, np.int64).reshape(-1, 2), pos.shape[0])
    pos = np.ascontiguousarray(pos, np.float64)
    got = _bending_pairs(offsets, flat, pos, np.float64(cos_limit))
    want = ref._bending_pairs(offsets, flat, pos, np.float64(cos_limit))
    np.testing.assert_array_equal(got, want)
    return got


@settings(max_examples=30)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 40), e=st.integers(0, 120), planar=st.booleans())
def test_random_graphs_match_reference(seed, n, e, planar):
    rng = np.random.default_rng(seed)
    pos = rng.uniform(-1.0, 1.0, (n, 3))
    if planar:
        pos[:, 2] = 0.0
    edges = np.sort(rng.integers(0, n, (e, 2)), axis=1)
    edges = np.unique(edges[edges[:, 0] != edges[:, 1]], axis=0).reshape(-1, 2)
    check(edges, pos, rng.uniform(-1.0, 0.0))


@pytest.mark.parametrize("quads", [False, True])
def test_grid_matches_reference(quads):
    """A regular grid is all ties (equal cosines): the pairs must still agree exactly."""
    mesh = grid(9, 7, spacing=0.1, quads=quads)
    counts = mesh.face_vertex_counts
    faces = mesh.face_vertex_indices.reshape(-1, counts[0])
    ring = [faces[:, [j, (j + 1) % faces.shape[1]]] for j in range(faces.shape[1])]
    edges = np.unique(np.sort(np.concatenate(ring), axis=1), axis=0)
    pairs = check(edges, mesh.vertex_pos.astype(np.float64))
    assert pairs.shape[0] > 0


def test_coincident_neighbour_has_no_direction():
    # j = 0 with neighbours 1 (at j itself), 2 (+x) and 3 (-x): 2 and 3 pair, 1 does not
    pos = np.array([[0, 0, 0], [0, 0, 0], [1, 0, 0], [-1, 0, 0]], np.float64)
    pairs = check(np.array([[0, 1], [0, 2], [0, 3]]), pos)
    np.testing.assert_array_equal(pairs, [[2, 3]])


def test_a_tie_goes_to_the_first_neighbour():
    # j = 0; neighbour 1 at +x faces 2 and 3 at exactly equal angles; both of those see 1 as
    # their most opposite: the pair is (1, 2), the first of the tied neighbours, so cooking
    # the same mesh always gives the same fabric
    pos = np.array([[0, 0, 0], [1, 0, 0], [-2, 1, 0], [-2, -1, 0]], np.float64)
    np.testing.assert_array_equal(check(np.array([[0, 1], [0, 2], [0, 3]]), pos), [[1, 2]])
    pos[[2, 3]] = pos[[3, 2]]
    np.testing.assert_array_equal(check(np.array([[0, 1], [0, 2], [0, 3]]), pos), [[1, 2]])


def test_angle_limit():
    # i-j-k at 150 degrees: a pair for a 135 degree limit, none for 160
    angle = np.radians(150.0)
    pos = np.array([[0, 0, 0], [1, 0, 0], [np.cos(angle), np.sin(angle), 0]], np.float64)
    edges = np.array([[0, 1], [0, 2]])
    assert check(edges, pos).shape == (1, 2)
    assert check(edges, pos, np.cos(np.radians(160.0))).shape == (0, 2)


def test_no_particles_or_edges():
    assert check(np.zeros((0, 2)), np.zeros((3, 3))).shape == (0, 2)
    assert check(np.zeros((0, 2)), np.zeros((0, 3))).shape == (0, 2)
