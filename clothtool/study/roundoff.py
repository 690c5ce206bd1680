"""The round-off floor of a study's runs: how much of an error is the particle state's precision.

A float32 run is baked a second time in float64 (its *twin*; a swept float64 run of the same
setting is reused when there is one) and the difference is its round-off, measured. On the
swinging sheet (benchmarks/figures/swing-convergence, XPBD, one second) it is 8e-4 of the
cloth's size at 768 Hz and grows with the iteration count to 5e-3 at 3072 Hz and 2e-2 at
6144 Hz, where it is the whole error; at 96-384 Hz (4e-3 .. 9e-3) the coarse, much stretched
swing amplifies the rounding differences instead.

A float64 run has no higher precision to compare with: its round-off is estimated as
eps * max|x| * N^2 / size, one unit of round-off per iteration fed back through the velocity
and summed over N iterations. It is an order of magnitude, not a bound: with float32's eps it
is 90-300x above the measured round-off of the swinging sheet at 768-6144 Hz, 5x at 384 Hz,
but 8x below it at 96 Hz. With float64's eps it stays below 1e-8 of the size up to 10^4
iterations a second for a second, far below any error a study resolves.

A run's error is *at the floor* when it is no more than FLOOR_MARGIN times the floor (its own
round-off plus the reference's): then at least half of the error may be round-off, and raising
the frequency cannot be expected to lower it.
"""

from __future__ import annotations

import math

import numpy as np

EPSILON = {"float32": float(np.finfo(np.float32).eps), "float64": float(np.finfo(np.float64).eps)}
FLOOR_MARGIN = 2.0
MEASURED = "measured against a float64 twin"
ESTIMATED = "estimate eps*|x|*N^2"
UNMEASURED = "not measured: the float64 twin went unstable"


def estimate(precision: str, iterations: int, extent: float, size: float) -> float:
    """Round-off bound (relative to the cloth's size) of ``iterations`` iterations on
    coordinates up to ``extent`` in ``precision``."""
    return EPSILON[precision] * extent * float(iterations) ** 2 / size


def extent(frames: dict) -> float:
    """Largest absolute coordinate over a bake's kept frames (scene units)."""
    return max((float(np.abs(points).max()) for clouds in frames.values() for points in clouds if points.size),
               default=0.0)


def floor_of(row: dict, key: str, reference_roundoff: float) -> float:
    """The row's floor for the metric column ``key``: its own round-off, plus the reference's
    for the errors measured against the reference (position)."""
    own = row["roundoff"].get(key, math.nan)
    if key.startswith("position"):
        return own + reference_roundoff
    return own


def at_floor(error: float, floor: float) -> bool:
    return math.isfinite(error) and math.isfinite(floor) and abs(error) <= FLOOR_MARGIN * floor
