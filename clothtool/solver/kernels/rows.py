"""Particle rows (x, y, z, w) to the (n, 3) arrays caches store.

numpy copies ``cur[:, :3]`` element by element through its strided-copy loop: ~120 us for
16k particles, 5% of a frame of the 128^2 benchmark cloth. These loops take ~16 us, and a
bake writes every frame.
"""

from __future__ import annotations

from clothtool._jit import kernel


@kernel
def copy_xyz(rows, out):
    """out[i] = rows[i, :3]."""
    for i in range(rows.shape[0]):
        out[i, 0] = rows[i, 0]
        out[i, 1] = rows[i, 1]
        out[i, 2] = rows[i, 2]


@kernel
def xyz_velocity(cur, prev, h, out):
    """out[i] = (cur[i, :3] - prev[i, :3]) / h, computed in h's precision."""
    for i in range(cur.shape[0]):
        out[i, 0] = (cur[i, 0] - prev[i, 0]) / h
        out[i, 1] = (cur[i, 1] - prev[i, 1]) / h
        out[i, 2] = (cur[i, 2] - prev[i, 2]) / h
