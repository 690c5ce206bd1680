"""Verlet integration (NvCloth's integrateParticles).

cur and prev hold positions in xyz and the inverse mass in w. prev.w is the particle's own
inverse mass (0 = pinned); cur.w may have been zeroed by a motion constraint or scaled by
collision during the last iteration and is restored here. Pinned particles do not move.
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel
from clothtool._simd import fill, keep_w, lane, load4, store4, vadd, vmul, vsub


@kernel
def integrate_linear(scale, bias, cur, prev):
    """x' = x + (x - x_prev) * scale + bias for every movable particle; x_prev = x.

    scale: damping times the time-step ratio; bias: (3,) gravity * dt^2 (plus frame terms).
    Rows are moved as <4 x float> vectors (clothtool._simd): one load and store each.
    """
    flat_cur = cur.reshape(-1)
    flat_prev = prev.reshape(-1)
    bias4 = np.zeros(4, cur.dtype)
    # element by element: a slice assignment compiles numba's shape-mismatch error message
    # (int and str formatting), ~2 s of a cold start for three numbers
    bias4[0] = bias[0]
    bias4[1] = bias[1]
    bias4[2] = bias[2]
    for i in range(cur.shape[0]):
        row = 4 * np.uintp(i)
        c = load4(flat_cur, row)
        p = load4(flat_prev, row)
        if lane(p, 3) > 0.0:
            moved = vadd(vadd(c, vmul(vsub(c, p), fill(c, scale))), load4(bias4, 0))
            store4(flat_cur, row, keep_w(moved, p))  # cur.w: the particle's own inverse mass again
        store4(flat_prev, row, keep_w(c, p))


@kernel
def mean_displacement(cur, prev, out):
    """out = sum m (x - x_prev) / sum m over the movable particles (prev.w > 0, m = 1 / prev.w):
    the cloth's mean motion over the last iteration (zeros when none is movable). Summed in
    float64 whatever the state's precision."""
    sx = 0.0
    sy = 0.0
    sz = 0.0
    total = 0.0
    for i in range(cur.shape[0]):
        w = prev[i, 3]
        if w > 0.0:
            m = 1.0 / np.float64(w)
            sx += m * (np.float64(cur[i, 0]) - np.float64(prev[i, 0]))
            sy += m * (np.float64(cur[i, 1]) - np.float64(prev[i, 1]))
            sz += m * (np.float64(cur[i, 2]) - np.float64(prev[i, 2]))
            total += m
    if total > 0.0:
        out[0] = sx / total
        out[1] = sy / total
        out[2] = sz / total
    else:
        out[0] = 0.0
        out[1] = 0.0
        out[2] = 0.0


@kernel
def integrate_free(scale, spared, gravity_bias, mean, cur, prev):
    """integrate_linear for a free cloth damped relative to its mean motion
    (clothtool.solver.integrate): bias = gravity_bias + spared * D, D the mean displacement
    (written to ``mean``), summed in float64; ``spared`` = step ratio - scale (0: no damping
    and no step change, gravity_bias alone)."""
    if spared == 0.0:
        integrate_linear(scale, gravity_bias, cur, prev)
        return
    mean_displacement(cur, prev, mean)
    bias = np.empty(3, cur.dtype)
    for k in range(3):
        bias[k] = np.float64(gravity_bias[k]) + spared * mean[k]
    integrate_linear(scale, bias, cur, prev)


@kernel(inline="always")
def _row(m, r, x, y, z):
    return m[r, 0] * x + m[r, 1] * y + m[r, 2] * z


@kernel
def integrate_affine(m_cur, m_prev, bias, cur, prev):
    """x' = x + M_cur x + M_prev x_prev + bias: Verlet in a moving (local) reference frame.

    m_cur, m_prev: (3,3) matrices folding damping, the frame's rotation and the inertia and
    drag of its motion; bias: (3,) gravity and linear frame terms (see solver.frame).
    """
    for i in range(cur.shape[0]):
        w = prev[i, 3]
        if w > 0.0:
            c0 = cur[i, 0]
            c1 = cur[i, 1]
            c2 = cur[i, 2]
            p0 = prev[i, 0]
            p1 = prev[i, 1]
            p2 = prev[i, 2]
            cur[i, 0] = c0 + _row(m_cur, 0, c0, c1, c2) + _row(m_prev, 0, p0, p1, p2) + bias[0]
            cur[i, 1] = c1 + _row(m_cur, 1, c0, c1, c2) + _row(m_prev, 1, p0, p1, p2) + bias[1]
            cur[i, 2] = c2 + _row(m_cur, 2, c0, c1, c2) + _row(m_prev, 2, p0, p1, p2) + bias[2]
            prev[i, 0] = c0
            prev[i, 1] = c1
            prev[i, 2] = c2
            cur[i, 3] = w
        else:
            for d in range(3):
                prev[i, d] = cur[i, d]
