"""Virtual particles: extra collision points inside triangles of coarse cloth.

Each is a triplet of particle indices plus a row of barycentric weights; collision treats the
weighted point like a particle and spreads its correction back onto the three particles.
"""

from __future__ import annotations

import numpy as np

from clothtool.fabric import VIRTUAL_BATCH_WIDTH
from clothtool.mesh.coloring import Schedule, TripletScheduler

# Barycentric weight patterns per triangle, by count: the centroid, and/or points two thirds
# of the way from the centroid towards each corner (which cover a triangle evenly).
_CENTROID = [(1 / 3, 1 / 3, 1 / 3)]
_CORNERS = [(2 / 3, 1 / 6, 1 / 6), (1 / 6, 2 / 3, 1 / 6), (1 / 6, 1 / 6, 2 / 3)]
WEIGHT_PATTERNS = {1: _CENTROID, 3: _CORNERS, 4: _CENTROID + _CORNERS}
# Width of a virtual-particle batch (NvCloth's SIMD width on CPU); validate() checks it.
BATCH_WIDTH = VIRTUAL_BATCH_WIDTH


def build_virtual_particles(
    triangles: np.ndarray, movable: np.ndarray, per_triangle: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Virtual particles for every triangle, scheduled into conflict-free batches.

    Returns (virtual_particles i32 (v,4), weights f32 (w,3), batch_offsets i32 (b+1,)).
    """
    if per_triangle == 0:
        return np.zeros((0, 4), np.int32), np.zeros((0, 3), np.float32), np.zeros(1, np.int32)
    weights = np.asarray(WEIGHT_PATTERNS[per_triangle], np.float32)
    t = triangles.shape[0]
    rows = np.empty((t * per_triangle, 4), np.int64)
    rows[:, :3] = np.repeat(triangles, per_triangle, axis=0)
    rows[:, 3] = np.tile(np.arange(per_triangle), t)
    schedule: Schedule = TripletScheduler(rows[:, :3], movable).batches(BATCH_WIDTH)
    return rows[schedule.order].astype(np.int32), weights, schedule.offsets
