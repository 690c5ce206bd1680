"""clothtool.mesh.coloring._greedy_colors against tests/reference/coloring.py."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clothtool.mesh.coloring import TripletScheduler, _greedy_colors
from clothtool.mesh.shapes import grid
from tests.reference import coloring as ref


def words_for(elements, movable):
    """The scheduler's bitmask size: enough words for any greedy colouring."""
    k = max(elements.shape[1], 1)
    return (k * max(TripletScheduler(elements, movable).lower_bound(), 1)) // 64 + 1


def check(elements, movable, words=None):
    elements = np.ascontiguousarray(elements, np.int64)
    movable = np.ascontiguousarray(movable, np.bool_)
    words = words_for(elements, movable) if words is None else words
    got = _greedy_colors(elements, movable, words)
    want = ref._greedy_colors(elements, movable, words)
    np.testing.assert_array_equal(got, want)
    # and the colouring is proper: one colour never moves a particle twice
    for color in np.unique(got):
        moving = elements[got == color].reshape(-1)
        moving = moving[movable[moving]]
        assert np.unique(moving).size == moving.size
    return got


@settings(max_examples=30)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 50), c=st.integers(0, 150), k=st.integers(2, 4))
def test_random_rows_match_reference(seed, n, c, k):
    rng = np.random.default_rng(seed)
    elements = np.array([rng.choice(n, k, replace=False) for _ in range(c)], np.int64).reshape(c, k)
    movable = rng.random(n) >= 0.2
    check(elements, movable)


def test_more_than_64_colours_use_the_second_word():
    """A fan of 100 pairs around one movable particle needs colours 0..99: two mask words."""
    elements = np.array([[0, i] for i in range(1, 101)], np.int64)
    colors = check(elements, np.ones(101, bool))
    np.testing.assert_array_equal(colors, np.arange(100))
    # around a pinned hub they never conflict: one colour
    movable = np.ones(101, bool)
    movable[0] = False
    np.testing.assert_array_equal(check(elements, movable), np.zeros(100))


@pytest.mark.parametrize("words", [1, 3])
def test_a_wider_mask_changes_nothing(words):
    rng = np.random.default_rng(4)
    elements = np.array([rng.choice(20, 2, replace=False) for _ in range(60)], np.int64)
    check(elements, np.ones(20, bool), words=max(words, words_for(elements, np.ones(20, bool))))


def test_grid_edges_in_locality_order():
    mesh = grid(12, 9)
    faces = mesh.face_vertex_indices.reshape(-1, 3)
    edges = np.unique(np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1), axis=0)
    movable = np.ones(mesh.vertex_count, bool)
    movable[:12] = False  # the top row pinned
    check(edges, movable)


def test_no_rows():
    assert check(np.zeros((0, 2), np.int64), np.ones(3, bool)).shape == (0,)
