"""The cook's cache tiles (clothtool.cook.tiles) and the solver's layers of independent
phases (clothtool.solver.fabric_layers).

Known answers: a cloth of one tile keeps the untiled schedule; every constraint lands in the
tile that its two particles' blocks name; the phases of interior tiles touch disjoint
particle blocks; hand-made particle ranges give the layers worked out by hand.
"""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.cook import tiles
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.fabric import PhaseType, conflicting_set
from clothtool.mesh.coloring import TripletScheduler
from clothtool.mesh.shapes import grid
from clothtool.solver.fabric_layers import phase_layers, phase_ranges
from clothtool.summary import fabric_summary

TILE = 128  # particles per tile in these tests: a 30 x 30 grid (900 particles) gets 8 blocks


def grid_phase_pairs(n: int):
    """Each phase's pairs of a cooked (RCM-ordered) n x n grid, and its movable mask."""
    fabric = cook_fabric(grid(n, n, 1.0 / (n - 1)), CookOptions(tethers="none")).fabric
    pairs = [fabric.constraint_indices[fabric.phase_constraints(p)].astype(np.int64) for p in range(fabric.phase_count)]
    return pairs, fabric.particle_inv_mass > 0


@pytest.fixture
def small_tiles(monkeypatch):
    monkeypatch.setattr(tiles, "TILE_PARTICLES", TILE)


def test_tile_ids_of_interior_and_seam_rows():
    pairs = np.array([[0, 3], [4, 7], [3, 4], [2, 9], [8, 9], [5, 8]])
    # blocks of 4 over 10 particles: [0,4) [4,8) [8,10) -> interior 0..2, seams 3 + block
    np.testing.assert_array_equal(tiles.tile_ids(pairs, 10, 4), [0, 1, 4, 5, 2, 5])


def test_one_tile_is_the_untiled_schedule():
    pairs, movable = grid_phase_pairs(12)
    for phase in pairs:
        tiled = tiles.schedule_tiles(phase, movable)
        plain = TripletScheduler(phase, movable).sets()
        np.testing.assert_array_equal(tiled.order, plain.order)
        np.testing.assert_array_equal(tiled.offsets, plain.offsets)
        np.testing.assert_array_equal(tiled.tiles, [0])
        assert tiled.lower_bound == plain.lower_bound


def test_tiled_sets_are_conflict_free_and_each_within_one_tile():
    pairs, movable = grid_phase_pairs(30)
    for phase in pairs:
        schedule = tiles.schedule_tiles(phase, movable, TILE)
        assert sorted(schedule.order.tolist()) == list(range(phase.shape[0]))  # every row once
        ids = tiles.tile_ids(phase, movable.shape[0], TILE)[schedule.order]
        assert schedule.tiles.shape[0] > 8  # interior tiles and seams
        assert np.all(np.diff(schedule.tiles) > 0)
        for t, tile in enumerate(schedule.tiles.tolist()):
            for s in range(schedule.tile_set_offsets[t], schedule.tile_set_offsets[t + 1]):
                rows = slice(schedule.offsets[s], schedule.offsets[s + 1])
                assert np.all(ids[rows] == tile)
                used = phase[schedule.order[rows]].reshape(-1)
                used = used[movable[used]]
                assert np.bincount(used).max() == 1
        # a tile's sets are as few as the untiled schedule's lower bound allows (greedy on a grid)
        sets_per_tile = np.diff(schedule.tile_set_offsets)
        assert sets_per_tile.max() <= max(2 * schedule.lower_bound - 1, 1)


def test_cook_lists_phases_tile_by_tile(small_tiles):
    mesh = grid(30, 30, 1.0 / 29)
    fabric = cook_fabric(mesh, CookOptions(tethers="none")).fabric
    assert conflicting_set(fabric) is None
    fabric.validate()
    # the same constraints as untiled (particles are numbered alike), each type once per tile
    # in NvCloth's order within a tile
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(tiles, "TILE_PARTICLES", 10**9)
        untiled = cook_fabric(mesh, CookOptions(tethers="none")).fabric
    assert untiled.phase_count == 4
    key = lambda f: sorted(zip(f.constraint_indices[:, 0].tolist(), f.constraint_indices[:, 1].tolist(), f.constraint_rest_length.tolist()))  # noqa: E731
    assert key(fabric) == key(untiled)
    types = [PhaseType(int(t)).label for t in fabric.phase_type]
    assert types[:4] == ["vertical", "horizontal", "shearing", "bending"]
    assert len(types) > 4 * 8
    blocks = -(-fabric.particle_count // TILE)
    lowest, highest = phase_ranges(fabric.constraint_indices, fabric.set_offsets, fabric.phase_set_offsets)
    interior = (lowest // TILE) == (highest // TILE)
    # interior tiles first, in block order, then the seams
    first_seam = int(np.argmin(interior))
    assert interior[:first_seam].all() and not interior[first_seam:].any()
    assert np.all(np.diff(lowest[:first_seam] // TILE) >= 0) and lowest[first_seam - 1] // TILE == blocks - 1
    summary = fabric_summary(fabric)
    assert [p["type"] for p in summary["phases"]] == ["vertical", "horizontal", "shearing", "bending"]
    assert sum(p["constraints"] for p in summary["phases"]) == fabric.constraint_count
    assert all(p["tiles"] > 8 for p in summary["phases"])


def test_cooked_tiles_solve_on_the_cores(small_tiles):
    """Interior tiles form one layer of one group per block; seams a layer of their own."""
    fabric = cook_fabric(grid(30, 30, 1.0 / 29), CookOptions(tethers="none")).fabric
    layers, groups = phase_layers(fabric.constraint_indices, fabric.set_offsets, fabric.phase_set_offsets)
    assert layers[-1] == groups.shape[0] - 1 and groups[-1] == fabric.phase_count
    blocks = -(-fabric.particle_count // TILE)
    assert layers[1] - layers[0] == blocks  # the interior tiles, all at once
    assert np.all(np.diff(groups[:blocks + 1]) == 4)  # each with its four phases in order
    _check_groups_disjoint(fabric.constraint_indices, fabric.set_offsets, fabric.phase_set_offsets, layers, groups)


def _check_groups_disjoint(indices, set_offsets, phase_set_offsets, layers, groups):
    """Brute force: the groups of a layer share no particle."""
    for layer in range(layers.shape[0] - 1):
        seen: set[int] = set()
        for g in range(layers[layer], layers[layer + 1]):
            first = set_offsets[phase_set_offsets[groups[g]]]
            last = set_offsets[phase_set_offsets[groups[g + 1]]]
            particles = set(indices[first:last].reshape(-1).tolist())
            assert not (particles & seen)
            seen |= particles


def layout(ranges):
    """Phases of one set and one constraint each, spanning the given particle ranges."""
    indices = np.array(ranges, np.int32).reshape(-1, 2)
    offsets = np.arange(indices.shape[0] + 1, dtype=np.int32)
    return indices, offsets, offsets.copy()


@pytest.mark.parametrize(
    "ranges, want_layers, want_groups",
    [
        ([(0, 9), (10, 19), (5, 15)], [0, 2, 3], [0, 1, 2, 3]),  # two blocks, then a seam over both
        ([(0, 9), (3, 5), (10, 12)], [0, 2], [0, 2, 3]),  # the second phase joins the first's group
        ([(0, 9), (10, 19), (12, 14)], [0, 2], [0, 1, 3]),  # joins the last group only
        ([(0, 9), (10, 19), (20, 29), (15, 22)], [0, 3, 4], [0, 1, 2, 3, 4]),  # meets the last and another
        ([(0, 9)], [0, 1], [0, 1]),
        ([], [0], [0]),
    ],
)
def test_layers_of_hand_made_ranges(ranges, want_layers, want_groups):
    layers, groups = phase_layers(*layout(ranges))
    np.testing.assert_array_equal(layers, want_layers)
    np.testing.assert_array_equal(groups, want_groups)


def test_a_phase_without_constraints_stays_with_its_group():
    indices = np.array([[0, 9], [10, 19]], np.int32)
    set_offsets = np.array([0, 1, 1, 2], np.int32)  # phase 1: one empty set
    phase_set_offsets = np.array([0, 1, 2, 3], np.int32)
    lowest, highest = phase_ranges(indices, set_offsets, phase_set_offsets)
    assert lowest[1] > highest[1]
    layers, groups = phase_layers(indices, set_offsets, phase_set_offsets)
    np.testing.assert_array_equal(layers, [0, 2])
    np.testing.assert_array_equal(groups, [0, 2, 3])


def test_random_layouts_give_disjoint_groups():
    rng = np.random.default_rng(5)
    for _ in range(50):
        phases = int(rng.integers(1, 12))
        per_phase = rng.integers(1, 4, phases)
        pairs = np.sort(rng.integers(0, 60, (int(per_phase.sum()), 2)), axis=1)
        set_offsets = np.arange(pairs.shape[0] + 1, dtype=np.int32)
        phase_set_offsets = np.concatenate([[0], np.cumsum(per_phase)]).astype(np.int32)
        layers, groups = phase_layers(pairs, set_offsets, phase_set_offsets)
        assert groups[-1] == phases and layers[-1] == groups.shape[0] - 1
        assert np.all(np.diff(groups) > 0) and np.all(np.diff(layers) > 0)
        _check_groups_disjoint(pairs, set_offsets, phase_set_offsets, layers, groups)
