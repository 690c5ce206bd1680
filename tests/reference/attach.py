"""Plain-numpy reference of clothtool.solver.kernels.attach."""

from __future__ import annotations

import numpy as np


def attach_particles(particle, pinned, start, end, alpha, centers, cur):
    value = (np.float32(1.0) - alpha) * start + alpha * end
    centers[particle] = value
    cur[particle[pinned], :3] = value[pinned]
