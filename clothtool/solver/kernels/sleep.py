"""The sleep test's measurement (NvCloth's updateSleepState): how far particles moved."""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel


@kernel
def max_displacement(cur, prev):
    """Largest |cur[i,:3] - prev[i,:3]| over all particles (0 for none), float64; inf when a
    position is not finite, so that a broken cloth never counts as still."""
    best = 0.0
    for i in range(cur.shape[0]):
        dx = np.float64(cur[i, 0]) - np.float64(prev[i, 0])
        dy = np.float64(cur[i, 1]) - np.float64(prev[i, 1])
        dz = np.float64(cur[i, 2]) - np.float64(prev[i, 2])
        d2 = dx * dx + dy * dy + dz * dz
        if not d2 <= best:
            if d2 != d2 or d2 == np.inf:
                return np.inf
            best = d2
    return np.sqrt(best)
