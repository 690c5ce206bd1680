"""Wind and air drag per triangle, accumulated into a force array: the air law of
``clothtool.solver.kernels.air``, as the position-based wind stage and the implicit
integrator apply it.

For a triangle (x0, x1, x2) with m = (x1 - x0) x (x2 - x0) and u = (v0 + v1 + v2) / 3 - wind
(its motion relative to the air), each corner receives

    -share_i * density * G(u, m)      density = rho s^3 / 12 (force in kg scene-units/s^2)

a third of the triangle's drag and lift (times the particle's share, ``clothtool.solver.air``:
1 on a triangle mesh) 1/2 rho C A |u|^2 (with its angle terms). (The talk
adds a force linear in the wind along the normal to each point; the law here is the same
quadratic drag and lift in all three integrators.) With still air it is the drag on the
moving cloth; a triangle without area or relative motion feels nothing. Pinned particles'
slots are written too (the integrator never reads them). The loop is sequential (triangles
share corners); it reads positions and velocities only, so the order changes the rounding
of the sums, nothing else.
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel
from clothtool.solver.kernels.air import triangle_air


@kernel
def wind_forces(triangles, share, air, drag, lift, density, cur, velocity, force):
    """triangles (t,3); share (n,): each particle's share in its triangles' force
    (``clothtool.solver.air``, 1 for a triangle mesh); air (3,) wind velocity (scene units/s); drag, lift: the aerodynamic
    coefficients C_d, C_l; density: rho s^3 / 12 (rho in kg/m^3, s metres per scene unit);
    cur (n,4); velocity (n,3); force (n,3) is added to."""
    third = np.float32(1.0 / 3.0)
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
        ux = (velocity[i0, 0] + velocity[i1, 0] + velocity[i2, 0]) * third - air[0]
        uy = (velocity[i0, 1] + velocity[i1, 1] + velocity[i2, 1]) * third - air[1]
        uz = (velocity[i0, 2] + velocity[i1, 2] + velocity[i2, 2]) * third - air[2]
        gx, gy, gz, ok = triangle_air(ux, uy, uz, e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x,
                                      drag, lift)
        if not ok:
            continue
        fx = -density * gx
        fy = -density * gy
        fz = -density * gz
        s0 = share[i0]
        s1 = share[i1]
        s2 = share[i2]
        force[i0, 0] += fx * s0
        force[i0, 1] += fy * s0
        force[i0, 2] += fz * s0
        force[i1, 0] += fx * s1
        force[i1, 1] += fy * s1
        force[i1, 2] += fz * s1
        force[i2, 0] += fx * s2
        force[i2, 1] += fy * s2
        force[i2, 2] += fz * s2
