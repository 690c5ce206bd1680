"""Reference for clothtool.solver.kernels.rows."""

from __future__ import annotations

import numpy as np


def copy_xyz(rows, out):
    """Returns rows[:, :3] in out's dtype."""
    return np.asarray(rows)[:, :3].astype(np.asarray(out).dtype)


def xyz_velocity(cur, prev, h, out):
    """Returns (cur[:, :3] - prev[:, :3]) / h in out's dtype, computed in h's dtype."""
    h = np.asarray(h)
    delta = np.asarray(cur)[:, :3].astype(h.dtype) - np.asarray(prev)[:, :3].astype(h.dtype)
    return (delta / h).astype(np.asarray(out).dtype)


def gather_xyz(rows, order, out):
    """Returns rows[order, :3] in out's dtype."""
    return np.asarray(rows)[np.asarray(order), :3].astype(np.asarray(out).dtype)


def vertex_rows(cur, prev, order, h, points, velocities):
    """Returns (gather_xyz of cur, gather_xyz of xyz_velocity) in points' and velocities' dtypes."""
    moved = xyz_velocity(cur, prev, h, np.zeros(0, np.float64))
    return gather_xyz(cur, order, points), gather_xyz(moved, order, velocities)
