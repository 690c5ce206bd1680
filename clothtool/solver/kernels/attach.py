"""Attachments: bound particles follow the body, interpolated across the frame."""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel


@kernel
def attach_particles(particle, pinned, start, end, alpha, centers, cur):
    """For bound particle j (index particle[j]) the attached position is
    start[j] + alpha * (end[j] - start[j]); it becomes the particle's motion-constraint centre
    (centers row), and a pinned one (pinned[j]) is put there (cur xyz)."""
    one = np.float32(1.0)
    for j in range(particle.shape[0]):
        i = particle[j]
        for axis in range(3):
            value = (one - alpha) * start[j, axis] + alpha * end[j, axis]
            centers[i, axis] = value
            if pinned[j]:
                cur[i, axis] = value
