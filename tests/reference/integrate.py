"""Reference for clothtool.solver.kernels.integrate: the seed's "Integration" section.

    delta = (x - x_prev) * scale + acceleration ;  x_prev = x ;  x += delta

for particles with a positive inverse mass (prev.w, the user's; pinned particles do not move,
but their x_prev still catches up with x). cur.w, which motion constraints may have zeroed and
collision may have scaled, is restored from prev.w (the seed's invMass notes: integrate restores
a zero cur.w, computeBounds a scaled one; the kernel's docstring folds both into integration).
"""

from __future__ import annotations

import numpy as np


def _split(cur, prev):
    cur = np.array(cur, np.float64)
    prev = np.array(prev, np.float64)
    movable = prev[:, 3] > 0.0
    return cur, prev, movable


def _finish(cur, prev, movable, new_xyz):
    old_xyz = cur[:, :3].copy()
    cur[movable, :3] = new_xyz[movable]
    cur[movable, 3] = prev[movable, 3]
    prev[:, :3] = old_xyz
    return cur, prev


def integrate_linear(scale, bias, cur, prev):
    """Returns (cur, prev) after one Verlet step; float64 copies, inputs untouched."""
    cur, prev, movable = _split(cur, prev)
    x, x_prev = cur[:, :3], prev[:, :3]
    delta = (x - x_prev) * np.float64(scale) + np.asarray(bias, np.float64)
    return _finish(cur, prev, movable, x + delta)


def _row(m, r, x, y, z):
    """Row r of the (3,3) matrix m applied to the vector (x, y, z)."""
    return float(np.dot(np.asarray(m, np.float64)[r], np.array([x, y, z], np.float64)))


def integrate_affine(m_cur, m_prev, bias, cur, prev):
    """x' = x + M_cur x + M_prev x_prev + bias (the seed's rotating-frame Verlet, with every
    frame term folded into two matrices and a bias); returns (cur, prev) as float64 copies."""
    cur, prev, movable = _split(cur, prev)
    x, x_prev = cur[:, :3], prev[:, :3]
    m_cur = np.asarray(m_cur, np.float64)
    m_prev = np.asarray(m_prev, np.float64)
    delta = x @ m_cur.T + x_prev @ m_prev.T + np.asarray(bias, np.float64)
    return _finish(cur, prev, movable, x + delta)


def mean_displacement(cur, prev):
    """(3,) sum m (x - x_prev) / sum m over particles with prev.w > 0, m = 1 / prev.w (zeros
    when there are none), in float64."""
    cur, prev, movable = _split(cur, prev)
    if not movable.any():
        return np.zeros(3)
    mass = 1.0 / prev[movable, 3]
    return mass @ (cur[movable, :3] - prev[movable, :3]) / mass.sum()


def integrate_free(scale, spared, gravity_bias, cur, prev):
    """integrate_linear for a free cloth damped relative to its mean motion: the bias is
    gravity_bias + spared * (mean displacement); returns (cur, prev) as float64 copies."""
    bias = np.asarray(gravity_bias, np.float64)
    if spared != 0.0:
        bias = bias + spared * mean_displacement(cur, prev)
    return integrate_linear(scale, bias, cur, prev)
