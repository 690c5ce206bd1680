"""Reference for clothtool.solver.kernels.sleep (NvCloth's updateSleepState measurement)."""

from __future__ import annotations

import numpy as np


def max_displacement(cur, prev):
    """Largest |cur - prev| over the particles' xyz (0 for none); inf if any is not finite."""
    d = np.asarray(cur, np.float64)[:, :3] - np.asarray(prev, np.float64)[:, :3]
    if d.shape[0] == 0:
        return 0.0
    if not np.isfinite(d).all():
        return np.inf
    return float(np.sqrt(np.einsum("ij,ij->i", d, d).max()))
