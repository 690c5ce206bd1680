"""TripletScheduler: conflict-freedom and set counts, as hypothesis properties."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.fabric import conflicting_set
from clothtool.mesh.coloring import TripletScheduler
from clothtool.mesh.shapes import grid


@st.composite
def constraint_sets(draw, k=2):
    n = draw(st.integers(k, 40))
    c = draw(st.integers(0, 120))
    rows = draw(
        st.lists(st.lists(st.integers(0, n - 1), min_size=k, max_size=k, unique=True), min_size=c, max_size=c)
    )
    movable = draw(st.lists(st.booleans(), min_size=n, max_size=n))
    elements = np.array(rows, np.int64).reshape(-1, k)
    return elements, np.array(movable, bool)


def check_schedule(elements, movable, schedule, width=None):
    order, offsets = schedule.order, schedule.offsets
    # every row scheduled exactly once
    assert sorted(order.tolist()) == list(range(elements.shape[0]))
    assert offsets[0] == 0 and offsets[-1] == elements.shape[0] and np.all(np.diff(offsets) >= 0)
    for s in range(schedule.set_count):
        rows = elements[order[offsets[s] : offsets[s + 1]]].reshape(-1)
        moving = rows[movable[rows]]
        assert len(set(moving.tolist())) == moving.size, f"set {s} repeats a movable particle"
        if width is not None:
            assert offsets[s + 1] - offsets[s] <= width


@given(constraint_sets())
def test_pair_sets_are_conflict_free_and_near_the_lower_bound(data):
    elements, movable = data
    schedule = TripletScheduler(elements, movable).sets()
    check_schedule(elements, movable, schedule)
    if elements.shape[0]:
        assert schedule.set_count >= schedule.lower_bound or schedule.lower_bound <= 1
        # greedy colouring of pairs needs at most 2 * max degree - 1 colours
        assert schedule.set_count <= max(2 * schedule.lower_bound - 1, 1)


@given(constraint_sets(k=3), st.integers(1, 8))
def test_triplet_batches_are_conflict_free_and_bounded_by_width(data, width):
    elements, movable = data
    schedule = TripletScheduler(elements, movable).batches(width)
    check_schedule(elements, movable, schedule, width)


def test_pinned_particles_never_conflict():
    # a star of constraints around pinned particle 0 fits in one set
    elements = np.array([[0, i] for i in range(1, 9)])
    movable = np.ones(9, bool)
    movable[0] = False
    assert TripletScheduler(elements, movable).sets().set_count == 1
    movable[0] = True
    assert TripletScheduler(elements, movable).sets().set_count == 8


def test_cooked_grid_sets_reach_the_lower_bound():
    result = cook_fabric(grid(20, 20, 0.05), CookOptions(tethers="none"))
    for phase in result.phases:
        assert phase.sets == phase.lower_bound, phase
    assert conflicting_set(result.fabric) is None


def test_sets_are_sorted_for_locality():
    fabric = cook_fabric(grid(10, 10, 0.1), CookOptions(tethers="none")).fabric
    for s in range(fabric.set_count):
        first = fabric.constraint_indices[fabric.set_offsets[s] : fabric.set_offsets[s + 1], 0]
        assert np.all(np.diff(first) >= 0)
