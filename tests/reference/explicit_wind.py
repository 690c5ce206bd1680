"""Reference for clothtool.integrators.explicit.kernels.explicit_wind: the air law per triangle.

Per triangle: m = (x1 - x0) x (x2 - x0), u = mean(v) - wind (its motion relative to the air),
and each corner j gets -share_j * density * G(u, m) of tests/reference/air.py (a third of the
triangle's drag and lift times the particle's share; pinned corners too). No area or no relative motion: nothing.
"""

from __future__ import annotations

import numpy as np

from tests.reference import air


def wind_forces(triangles, share, air_velocity, drag, lift, density, cur, velocity, force):
    """Returns force (float64 copy) after adding every triangle's wind; inputs untouched."""
    tri = np.asarray(triangles)
    x = np.asarray(cur, np.float64)[:, :3]
    velocity = np.asarray(velocity, np.float64)
    out = np.array(force, np.float64)
    for ids in tri:
        m = np.cross(x[ids[1]] - x[ids[0]], x[ids[2]] - x[ids[0]])
        u = velocity[ids].mean(axis=0) - np.asarray(air_velocity, np.float64)
        gx, gy, gz, ok = air.triangle_air(*u, *m, float(drag), float(lift))
        if ok:
            out[ids] -= float(density) * np.outer(np.asarray(share, np.float64)[ids], [gx, gy, gz])
    return out
