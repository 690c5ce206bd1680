"""Particle rows (x, y, z, w) to the (n, 3) arrays caches store.

numpy copies ``cur[:, :3]`` element by element through its strided-copy loop: ~120 us for
16k particles, 5% of a frame of the 128^2 benchmark cloth. These loops take ~16 us, and a
bake writes every frame. ``gather_xyz`` puts rows into the mesh's vertex order (a cook
that renumbers particles for locality) and into the cache's float32 in one pass: numpy's
``take`` and ``astype`` took ~50 us, this ~15 us.
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


@kernel
def gather_xyz(rows, order, out):
    """out[v] = rows[order[v], :3] in out's dtype: particle rows into the mesh's vertex order."""
    for v in range(order.shape[0]):
        i = order[v]
        out[v, 0] = rows[i, 0]
        out[v, 1] = rows[i, 1]
        out[v, 2] = rows[i, 2]
