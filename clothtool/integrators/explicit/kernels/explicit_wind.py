"""Wind per triangle (the talk's "Wind Forces"), accumulated into a force array.

The talk takes the triangle normal from a cross product, scales the (unit) normal by its dot
product with the wind and adds that to the triangle's points, noting that the force is
proportional to the triangle's area. Here, for a triangle (x0, x1, x2):

    m = (x1 - x0) x (x2 - x0),  A = |m| / 2,  n = m / |m|
    u = wind - (v0 + v1 + v2) / 3                 (the air seen by the moving triangle)
    F = coefficient * A * (n . u) * n             (along the normal, proportional to area)

and each corner receives F / 3, so that the corners together feel the triangle's force (the
talk adds the whole force to each point). The sign of n does not matter (F has n twice);
with u = 0 the wind is still air and F is the air drag on the moving cloth. A degenerate
triangle (|m| = 0) feels nothing. Pinned particles' slots are written too (the integrator
never reads them). The loop is sequential (triangles share corners); it reads positions and
velocities only, so the order changes the rounding of the sums, nothing else.
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel


@kernel
def wind_forces(triangles, air, coefficient, cur, velocity, force):
    """triangles (t,3); air (3,) wind velocity (scene units/s); coefficient: drag per unit
    area and unit normal speed (scene units, kg/(units^2 s)); cur (n,4); velocity (n,3);
    force (n,3) is added to."""
    zero = np.float32(0.0)
    third = np.float32(1.0 / 3.0)
    sixth = np.float32(1.0 / 6.0)
    for t in range(triangles.shape[0]):
        i0 = triangles[t, 0]
        i1 = triangles[t, 1]
        i2 = triangles[t, 2]
        e1x = cur[i1, 0] - cur[i0, 0]
        e1y = cur[i1, 1] - cur[i0, 1]
        e1z = cur[i1, 2] - cur[i0, 2]
        e2x = cur[i2, 0] - cur[i0, 0]
        e2y = cur[i2, 1] - cur[i0, 1]
        e2z = cur[i2, 2] - cur[i0, 2]
        mx = e1y * e2z - e1z * e2y
        my = e1z * e2x - e1x * e2z
        mz = e1x * e2y - e1y * e2x
        double_area = np.sqrt(mx * mx + my * my + mz * mz)
        if double_area == zero:
            continue
        ux = air[0] - (velocity[i0, 0] + velocity[i1, 0] + velocity[i2, 0]) * third
        uy = air[1] - (velocity[i0, 1] + velocity[i1, 1] + velocity[i2, 1]) * third
        uz = air[2] - (velocity[i0, 2] + velocity[i1, 2] + velocity[i2, 2]) * third
        # coefficient * A * (n . u) * n / 3 with A = |m| / 2 and n = m / |m|: c (m . u) m / (6 |m|)
        scale = coefficient * sixth * (mx * ux + my * uy + mz * uz) / double_area
        fx = scale * mx
        fy = scale * my
        fz = scale * mz
        force[i0, 0] += fx
        force[i0, 1] += fy
        force[i0, 2] += fz
        force[i1, 0] += fx
        force[i1, 1] += fy
        force[i1, 2] += fz
        force[i2, 0] += fx
        force[i2, 1] += fy
        force[i2, 2] += fz
