"""The round-off floor of a study's runs: how much of an error is the particle state's precision.

A float32 run is baked a second time in float64 (its *twin*; a swept float64 run of the same
setting is reused when there is one) and the difference is its round-off, measured. On the
swinging sheet that grows about as N^2.3 with the iteration count N: 4e-5 of the cloth's size
at 384 Hz, 9e-4 at 1536 Hz, 2e-2 at 6144 Hz, so float32 errors stop falling with frequency.

A float64 run has no higher precision to compare with: its round-off is estimated as
eps * max|x| * N^2 / size, the bound a position error of one unit of round-off per iteration,
fed back into the velocity and summed over N iterations, could reach. With float32's eps this
bound is 100-250x above the measured round-off on the swinging sheet at 384-6144 Hz, so it
marks only errors that round-off could really explain.

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
