"""Verlet integration (NvCloth's integrateParticles).

cur and prev hold positions in xyz and the inverse mass in w. prev.w is the particle's own
inverse mass (0 = pinned); cur.w may have been zeroed by a motion constraint or scaled by
collision during the last iteration and is restored here. Pinned particles do not move.
"""

from __future__ import annotations


from clothtool._jit import kernel


@kernel
def integrate_linear(scale, bias, cur, prev):
    """x' = x + (x - x_prev) * scale + bias for every movable particle; x_prev = x.

    scale: damping times the time-step ratio; bias: (3,) gravity * dt^2 (plus frame terms).
    """
    for i in range(cur.shape[0]):
        w = prev[i, 3]
        if w > 0.0:
            for d in range(3):
                c = cur[i, d]
                cur[i, d] = c + (c - prev[i, d]) * scale + bias[d]
                prev[i, d] = c
            cur[i, 3] = w
        else:
            for d in range(3):
                prev[i, d] = cur[i, d]


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
