"""Reference for clothtool.integrators.explicit.kernels.explicit_wind: the talk's wind force.

Per triangle: the unit normal n of (x1 - x0) x (x2 - x0), its area A, the air relative to the
triangle's mean velocity u = wind - mean(v), and the force F = coefficient * A * (n . u) n,
split in thirds among its corners (pinned ones too). A degenerate triangle feels nothing.
"""

from __future__ import annotations

import numpy as np


def wind_forces(triangles, air, coefficient, cur, velocity, force):
    """Returns force (float64 copy) after adding every triangle's wind; inputs untouched."""
    tri = np.asarray(triangles)
    cur = np.asarray(cur, np.float64)
    velocity = np.asarray(velocity, np.float64)
    out = np.array(force, np.float64)
    x = cur[:, :3]
    m = np.cross(x[tri[:, 1]] - x[tri[:, 0]], x[tri[:, 2]] - x[tri[:, 0]])
    norm = np.linalg.norm(m, axis=1)
    ok = norm > 0
    n = np.zeros_like(m)
    n[ok] = m[ok] / norm[ok, None]
    area = 0.5 * norm
    u = np.asarray(air, np.float64) - velocity[tri].mean(axis=1)
    f = float(coefficient) * area[:, None] * np.sum(n * u, axis=1)[:, None] * n
    for corner in range(3):
        np.add.at(out, tri[:, corner], f / 3.0)
    return out
