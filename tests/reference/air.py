"""Reference for clothtool.solver.kernels.air: the drag and lift law, written with angles.

For a triangle with unnormalised normal m (a = |m| twice its area, n = m / a) moving at u
relative to the air, with cos = n.u / |u| and sin = sqrt(1 - cos^2):

    G = a (C_d |cos| |u| u + C_l cos sin |u|^2 l)        l = unit((u x n) x u)

and the force on the triangle is -rho/4 G (1/2 rho C A |u|^2 with A = a / 2). No motion, no
area or u along the normal (no lift direction) give the terms that vanish there.
"""

from __future__ import annotations

import numpy as np


def triangle_air(ux, uy, uz, mx, my, mz, drag, lift):
    """(G_x, G_y, G_z, ok) as the kernel returns them (G only where ok)."""
    u = np.array([ux, uy, uz], np.float64)
    m = np.array([mx, my, mz], np.float64)
    double_area = np.linalg.norm(m)
    speed = np.linalg.norm(u)
    if speed == 0.0 or double_area == 0.0:
        return 0.0, 0.0, 0.0, False
    n = m / double_area
    cos_theta = float(n @ u) / speed
    sin_theta = np.sqrt(max(0.0, 1.0 - cos_theta * cos_theta))
    lift_dir = np.cross(np.cross(u, n), u)
    size = np.linalg.norm(lift_dir)
    lift_hat = lift_dir / size if size > 0 else np.zeros(3)
    g = double_area * (drag * abs(cos_theta) * speed * u + lift * cos_theta * sin_theta * speed * speed * lift_hat)
    return float(g[0]), float(g[1]), float(g[2]), True
