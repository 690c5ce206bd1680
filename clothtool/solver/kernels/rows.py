"""Particle rows (x, y, z, w) to the (n, 3) arrays caches store.

numpy copies ``cur[:, :3]`` element by element through its strided-copy loop: ~120 us for
16k particles, 5% of a frame of the 128^2 benchmark cloth. These loops take ~16 us, and a
bake writes every frame. ``gather_xyz`` puts rows into the mesh's vertex order (a cook
that renumbers particles for locality) and into the cache's float32 in one pass: numpy's
``take`` and ``astype`` took ~50 us, this ~15 us.
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel
from clothtool._minmax import smallest
from clothtool._simd import load4, store4, vsub

_VELOCITY_BLOCK = 64  # rows divided as one run by xyz_velocity


@kernel
def copy_xyz(rows, out):
    """out[i] = rows[i, :3]."""
    for i in range(rows.shape[0]):
        out[i, 0] = rows[i, 0]
        out[i, 1] = rows[i, 1]
        out[i, 2] = rows[i, 2]


@kernel
def xyz_velocity(cur, prev, h, out):
    """out[i] = (cur[i, :3] - prev[i, :3]) / h, computed in h's precision (C-contiguous
    rows of 4).

    The divisions are its cost. Row by row (read 4 apart, written 3 apart) LLVM does not
    vectorise them: ~65 us for 16k particles. Here each block of 64 rows is divided whole
    (w included) as one contiguous run, which vectorises, into a small float64 scratch that
    holds any quotient exactly, and then its x, y, z go to ``out``: ~37 us, the same bits."""
    n = cur.shape[0]
    flat_cur = cur.reshape(-1)
    flat_prev = prev.reshape(-1)
    quotients = np.empty(4 * _VELOCITY_BLOCK, np.float64)  # one small allocation per call
    for start in range(0, n, _VELOCITY_BLOCK):
        rows = smallest(_VELOCITY_BLOCK, n - start)
        c = flat_cur[4 * start : 4 * (start + rows)]
        p = flat_prev[4 * start : 4 * (start + rows)]
        for j in range(c.shape[0]):
            quotients[j] = (c[j] - p[j]) / h
        for r in range(rows):
            out[start + r, 0] = quotients[4 * r]
            out[start + r, 1] = quotients[4 * r + 1]
            out[start + r, 2] = quotients[4 * r + 2]


@kernel
def gather_xyz(rows, order, out):
    """out[v] = rows[order[v], :3] in out's dtype: particle rows into the mesh's vertex order."""
    for v in range(order.shape[0]):
        i = order[v]
        out[v, 0] = rows[i, 0]
        out[v, 1] = rows[i, 1]
        out[v, 2] = rows[i, 2]


@kernel
def vertex_rows(cur, prev, order, h, points, velocities):
    """A cache frame's rows from the state in one pass: points[v] = cur[order[v], :3] and
    velocities[v] = (cur - prev)[order[v], :3] / h (in h's precision), each converted to its
    array's dtype: the bits of gather_xyz over copy_xyz's and xyz_velocity's rows, without
    their two (n, 3) arrays in particle order. Each block of rows is gathered (a row a load)
    into a contiguous scratch and divided whole there (vectorised, as in xyz_velocity)."""
    flat_cur = cur.reshape(-1)
    flat_prev = prev.reshape(-1)
    block_cur = np.empty(4 * _VELOCITY_BLOCK, cur.dtype)
    block_delta = np.empty(4 * _VELOCITY_BLOCK, cur.dtype)
    quotients = np.empty(4 * _VELOCITY_BLOCK, np.float64)  # holds any quotient exactly
    n = order.shape[0]
    for start in range(0, n, _VELOCITY_BLOCK):
        rows = smallest(_VELOCITY_BLOCK, n - start)
        for r in range(rows):
            i = 4 * order[start + r]
            row = load4(flat_cur, i)
            store4(block_cur, 4 * r, row)
            store4(block_delta, 4 * r, vsub(row, load4(flat_prev, i)))
        for j in range(4 * rows):
            quotients[j] = block_delta[j] / h
        for r in range(rows):
            points[start + r, 0] = block_cur[4 * r]
            points[start + r, 1] = block_cur[4 * r + 1]
            points[start + r, 2] = block_cur[4 * r + 2]
            velocities[start + r, 0] = quotients[4 * r]
            velocities[start + r, 1] = quotients[4 * r + 1]
            velocities[start + r, 2] = quotients[4 * r + 2]
