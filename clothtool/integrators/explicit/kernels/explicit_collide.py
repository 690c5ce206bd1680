"""Collisions after the position update: the shared collision geometry, the explicit response.

The geometry is the position-based solver's (``clothtool.solver.kernels.collide``
``point_correction``, on the records ``clothtool.solver.collide.CollideStage`` poses for the
substep): each particle's path over the substep, from its start ``prev`` (symplectic Euler
stores it there) to ``cur``, is tested continuously against the spheres and capsules (a
particle that would end beyond one is put back on its surface where it hit, on the side it
came from), then the discrete contacts at the end are averaged (push-out d, surface
displacement s, friction budget mu |d|); meshes decide a particle's side from its start, so
nothing tunnels through a collider, however fast. The response is this integrator's own:

* the particle moves by the correction c = continuous move + d (to the grown surface);
* its velocity relative to the collider's surface velocity v_c = s / h (after a continuous
  move, the velocity of the path start -> corrected end: it was carried by the collider),
  r = v - v_c, loses its inward part along n = c / |c| (inelastic): with r_n = r . n < 0,
  the impulse per mass is -r_n;
* Coulomb friction (none after a continuous move): the tangential part r_t = r - r_n n
  shrinks by at most mu |r_n| (it stops when |r_t| <= mu |r_n|), mu = budget / |d|:
  r_t *= max(0, 1 - mu |r_n| / |r_t|);
* v = v_c + r_t, and prev = cur - h v, so that (cur - prev) / h stays the velocity.

A particle moving out of the collider (r_n >= 0) keeps its velocity.
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel
from clothtool.solver.kernels.collide import point_correction


@kernel(inline="always")
def _respond(i, tx, ty, tz, nx, ny, nz, vcx, vcy, vcz, mu, h, cur, prev, velocity):
    """Move particle i to (tx, ty, tz), remove its inward velocity along the unit normal n
    relative to v_c, apply Coulomb friction mu to the tangential part, and set prev."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    cur[i, 0] = tx
    cur[i, 1] = ty
    cur[i, 2] = tz
    rx = velocity[i, 0] - vcx
    ry = velocity[i, 1] - vcy
    rz = velocity[i, 2] - vcz
    rn = rx * nx + ry * ny + rz * nz
    if rn < zero:
        ux = rx - rn * nx
        uy = ry - rn * ny
        uz = rz - rn * nz
        slide = np.sqrt(ux * ux + uy * uy + uz * uz)
        keep = zero
        if slide > zero:
            keep = max(zero, one + mu * rn / slide)
        velocity[i, 0] = vcx + ux * keep
        velocity[i, 1] = vcy + uy * keep
        velocity[i, 2] = vcz + uz * keep
    prev[i, 0] = cur[i, 0] - h * velocity[i, 0]
    prev[i, 1] = cur[i, 1] - h * velocity[i, 1]
    prev[i, 2] = cur[i, 2] - h * velocity[i, 2]


@kernel
def collide_colliders(shapes, mesh, frame, h, cur, prev, velocity):
    """Collide every movable particle (cur.w > 0) over the substep of length h (module
    docstring): ``shapes``, ``mesh``, ``frame`` as the position-based collide kernels read
    them; prev (n,4) holds the substep's start positions; cur, prev and velocity (n,3) are
    updated in place."""
    zero = np.float32(0.0)
    for i in range(cur.shape[0]):
        if not cur[i, 3] > zero:
            continue
        px = cur[i, 0]
        py = cur[i, 1]
        pz = cur[i, 2]
        qx = prev[i, 0]
        qy = prev[i, 1]
        qz = prev[i, 2]
        count, mx, my, mz, dx, dy, dz, sx, sy, sz, budget = point_correction(
            px, py, pz, qx, qy, qz, shapes, mesh, frame, True
        )
        cx = mx + dx
        cy = my + dy
        cz = mz + dz
        size = np.sqrt(cx * cx + cy * cy + cz * cz)
        if size <= zero:
            continue
        tx = px + cx
        ty = py + cy
        tz = pz + cz
        mu = zero
        if mx == zero and my == zero and mz == zero:
            push = np.sqrt(dx * dx + dy * dy + dz * dz)
            mu = budget / push if push > zero else zero
            vcx = sx / h
            vcy = sy / h
            vcz = sz / h
        else:  # a continuous move: carried from the start to where it hit, without friction
            vcx = (tx - qx) / h
            vcy = (ty - qy) / h
            vcz = (tz - qz) / h
        _respond(i, tx, ty, tz, cx / size, cy / size, cz / size, vcx, vcy, vcz, mu, h, cur, prev, velocity)
