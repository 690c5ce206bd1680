"""Reference for clothtool.integrators.explicit.kernels.explicit_integrate: symplectic Euler.

Movable particles (cur.w > 0): v' = v + h (g + w f), prev' = x, x' = x + h v'. Pinned
particles keep position, prev and velocity.
"""

from __future__ import annotations

import numpy as np


def symplectic_euler(gravity, h, force, cur, prev, velocity):
    """Returns (cur, prev, velocity) as float64 copies after one step; inputs untouched."""
    cur = np.array(cur, np.float64)
    prev = np.array(prev, np.float64)
    velocity = np.array(velocity, np.float64)
    movable = cur[:, 3] > 0
    w = cur[movable, 3:4]
    h = float(h)
    v = velocity[movable] + h * (np.asarray(gravity, np.float64) + w * np.asarray(force, np.float64)[movable])
    velocity[movable] = v
    prev[movable, :3] = cur[movable, :3]
    cur[movable, :3] += h * v
    return cur, prev, velocity
