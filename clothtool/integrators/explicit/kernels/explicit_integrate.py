"""Symplectic (semi-implicit) Euler: the velocity first, then the position with the new velocity.

For each movable particle (cur.w = inverse mass > 0):

    v += h (g + w f) ;  prev = x ;  x += h v

so prev = x - h v afterwards and (cur - prev) / h is the velocity the meters and cache writers
read. Gravity enters as an acceleration (so free fall is exact whatever the mass), the other
forces through the inverse mass. Pinned particles (w = 0) are not touched at all: their
position stays bit for bit, their velocity (zero) and prev (= cur) too.
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel


@kernel
def symplectic_euler(gravity, h, force, cur, prev, velocity):
    """gravity (3,) scene units/s^2; h: step in s; force (n,3) (kg * units / s^2); cur, prev
    (n,4) and velocity (n,3) are updated in place."""
    zero = np.float32(0.0)
    for i in range(cur.shape[0]):
        w = cur[i, 3]
        if w > zero:
            for d in range(3):
                v = velocity[i, d] + h * (gravity[d] + w * force[i, d])
                velocity[i, d] = v
                x = cur[i, d]
                prev[i, d] = x
                cur[i, d] = x + h * v
