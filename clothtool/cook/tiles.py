"""Cache tiles: a big cloth's constraints scheduled particle block by particle block.

Each conflict-free set of a phase is spread over the whole cloth, so solving the phases set
after set reads every particle once per set: twelve times an iteration for a grid. At 10k
particles the state stays in L2 between sets; at 1M (32 MB of float64 state) every set
reads it from memory and the fabric costs 2.3 times as much per particle
(``python benchmarks/locality.py``).

The cook therefore cuts a cloth of more than ``TILE_PARTICLES`` particles into *tiles*.
Particles are numbered for locality first (reverse Cuthill-McKee, clothtool.cook.locality),
so consecutive particle indices are neighbours and blocks of ``TILE_PARTICLES`` consecutive
particles are patches of cloth. A constraint whose two particles lie in one block belongs to
that block's *interior tile*; a constraint that crosses from block b-1 into block b belongs
to the *seam tile* of boundary b. The fabric then lists its phases tile by tile (the four
phases of tile 0, those of tile 1, ..., interior tiles first, then the seams), each
(tile, phase) scheduled into conflict-free sets on its own (clothtool.mesh.coloring). One
tile's particles (512 KB of float64 state) stay in L2 while all its phases' sets sweep them,
so memory sees each particle about twice per iteration instead of once per set.

Interior tiles share no particle, and seam tiles share none when the ordering's bandwidth
is under half a tile (RCM's on any garment-like mesh), so the solver solves them on all
cores, tile by tile, with the same bits as one thread (clothtool.solver.fabric_layers
checks the independence rather than trusting it). A cloth of at most ``TILE_PARTICLES``
particles is one tile: its phases and sets are exactly the untiled schedule.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from clothtool.mesh.coloring import TripletScheduler

# 16384 particles: 512 KB of float64 state (256 KB in float32), half of one core's L2 here,
# leaving room for the constraint data streaming through. Measured on a 1000^2 grid: 8192
# and 16384 cost the same, 4096 more (tiles too small for the seams' share), and a cloth
# of at most this many particles keeps the untiled schedule its goldens were made with.
TILE_PARTICLES = 16384


@dataclasses.dataclass(frozen=True)
class TileSchedule:
    """One phase's constraints scheduled tile by tile.

    order: i64 (c,) input row of each scheduled row (tiles in ``tiles`` order, each tile's
        sets in order); offsets: i64 (s+1,) CSR of the sets over the scheduled rows;
        tiles: i64 (t,) the tile ids present, ascending; tile_set_offsets: i64 (t+1,) CSR of
        the tiles over the sets; lower_bound: the largest number of rows meeting at one
        movable particle (no untiled schedule has fewer sets).
    """

    order: np.ndarray
    offsets: np.ndarray
    tiles: np.ndarray
    tile_set_offsets: np.ndarray
    lower_bound: int

    @property
    def set_count(self) -> int:
        return int(self.offsets.shape[0]) - 1


def tile_ids(pairs: np.ndarray, particle_count: int, tile_particles: int) -> np.ndarray:
    """i64 (c,): the tile of each constraint row. Blocks b = 0..m-1 of ``tile_particles``
    particles; interior tile b for a row within block b, seam tile m + b for a row whose
    highest particle is in block b and lowest in an earlier block."""
    blocks = -(-particle_count // tile_particles)
    lo = pairs.min(axis=1) // tile_particles
    hi = pairs.max(axis=1) // tile_particles
    return np.where(lo == hi, lo, blocks + hi)


def schedule_tiles(pairs: np.ndarray, movable: np.ndarray, tile_particles: int | None = None) -> TileSchedule:
    """Conflict-free sets of ``pairs`` (c,k), tile by tile (see the module docs); tiles of
    ``tile_particles`` particles (default ``TILE_PARTICLES``)."""
    tile_particles = tile_particles or TILE_PARTICLES
    pairs = np.ascontiguousarray(pairs, np.int64)
    scheduler = TripletScheduler(pairs, movable)
    lower_bound = scheduler.lower_bound()
    if movable.shape[0] <= tile_particles or pairs.shape[0] == 0:
        whole = scheduler.sets()
        tiles = np.zeros(1 if whole.set_count else 0, np.int64)
        return TileSchedule(whole.order, whole.offsets.astype(np.int64), tiles,
                            np.array([0, whole.set_count] if whole.set_count else [0], np.int64), lower_bound)
    tile = tile_ids(pairs, movable.shape[0], tile_particles)
    rows_by_tile = np.argsort(tile, kind="stable")
    present, starts = np.unique(tile[rows_by_tile], return_index=True)
    ends = np.append(starts[1:], rows_by_tile.shape[0])
    orders, set_offsets, tile_set_offsets = [], [np.zeros(1, np.int64)], [0]
    done = 0
    for first, last in zip(starts.tolist(), ends.tolist()):
        rows = rows_by_tile[first:last]
        local = pairs[rows]
        # The tile's particles lie in [low, high]: schedule it with indices shifted to 0 so
        # that the scheduler's per-particle table is the tile's size, not the cloth's.
        low, high = int(local.min()), int(local.max())
        sets = TripletScheduler(local - low, movable[low:high + 1]).sets()
        orders.append(rows[sets.order])
        set_offsets.append(sets.offsets[1:].astype(np.int64) + done)
        done += last - first
        tile_set_offsets.append(tile_set_offsets[-1] + sets.set_count)
    return TileSchedule(np.concatenate(orders), np.concatenate(set_offsets), present.astype(np.int64),
                        np.asarray(tile_set_offsets, np.int64), lower_bound)
