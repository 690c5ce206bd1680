"""Reference for clothtool.integrators.explicit.kernels.explicit_springs: the talk's spring and
damping forces, with the restoring sign.

Per spring (a, b) of rest length L, stiffness k and damper c, with d = x_b - x_a, l = |d|,
u = d / l and the relative velocity r = v_b - v_a:

    F = (k (l - L) + c (r . u)) u ;   force_a += F ;  force_b -= F

A zero-length spring exerts nothing. ``spring_forces`` writes every particle; the set kernel
``spring_forces_sets`` applies the springs of its sets to movable particles (cur.w > 0) only.
Springs are independent, so the reference sums them all at once (np.add.at).
"""

from __future__ import annotations

import numpy as np


def _spring_force(c, indices, rest, stiffness, damping, cur, velocity):
    """Force (3,) of spring c on its first particle."""
    a, b = (int(i) for i in np.asarray(indices)[c])
    d = np.asarray(cur, np.float64)[b, :3] - np.asarray(cur, np.float64)[a, :3]
    length = float(np.linalg.norm(d))
    if length == 0.0:
        return np.zeros(3)
    u = d / length
    r = np.asarray(velocity, np.float64)[b] - np.asarray(velocity, np.float64)[a]
    return (float(stiffness[c]) * (length - float(rest[c])) + float(damping[c]) * float(r @ u)) * u


def _forces(indices, rest, stiffness, damping, cur, velocity):
    """(c,3) force of each spring on its first particle, vectorised."""
    cur = np.asarray(cur, np.float64)
    velocity = np.asarray(velocity, np.float64)
    a, b = indices[:, 0], indices[:, 1]
    d = cur[b, :3] - cur[a, :3]
    length = np.linalg.norm(d, axis=1)
    ok = length > 0
    u = np.zeros_like(d)
    u[ok] = d[ok] / length[ok, None]
    magnitude = np.asarray(stiffness, np.float64) * (length - np.asarray(rest, np.float64))
    magnitude += np.asarray(damping, np.float64) * np.sum((velocity[b] - velocity[a]) * u, axis=1)
    return np.where(ok[:, None], magnitude[:, None] * u, 0.0)


def spring_forces(indices, rest, stiffness, damping, cur, velocity, force):
    """Returns force (float64 copy) after adding every spring's force to both ends."""
    indices = np.asarray(indices)
    f = _forces(indices, rest, stiffness, damping, cur, velocity)
    out = np.array(force, np.float64)
    np.add.at(out, indices[:, 0], f)
    np.add.at(out, indices[:, 1], -f)
    return out


def spring_forces_sets(indices, rest, stiffness, damping, set_offsets, cur, velocity, force):
    """Returns force (float64 copy) after adding the forces of the springs in the sets
    (the first set_offsets[-1] springs) to their movable ends."""
    count = int(np.asarray(set_offsets)[-1])
    indices = np.asarray(indices)[:count]
    f = _forces(indices, rest[:count], stiffness[:count], damping[:count], cur, velocity)
    movable = np.asarray(cur)[:, 3] > 0
    out = np.array(force, np.float64)
    a, b = indices[:, 0], indices[:, 1]
    np.add.at(out, a[movable[a]], f[movable[a]])
    np.add.at(out, b[movable[b]], -f[movable[b]])
    return out
