"""Cloth-collider contact for the implicit integrator: the shared collision geometry, Bridson's
response (Bridson, Fedkiw & Anderson 2002, as the slides 23-30 describe).

Geometry. The colliders are posed for the step by the position-based solver's stage
(``clothtool.solver.collide.CollideStage``: linear motion over the frame, records with the
cloth's thickness in every margin, one triangle grid) and read through
``clothtool.solver.kernels.collide.point_correction``: for a point moving x0 -> x1 over the
step it gives the continuous move (a point that would end beyond a sphere or capsule goes
back on its surface where it hit, on the side it came from) and the average push-out d of
the discrete contacts (to the grown surface; a mesh face's side is the one the point started
on, so thin sheets are solid from both sides and nothing tunnels through a mesh), the
average surface displacement s and friction budget mu |d|. A contact is summarised as
(phi, normal xyz, friction, collider velocity xyz) with the correction c = move + d (none
when |c| <= 1e-7 (1 + |x|_max), float32 rounding of the records):
phi = -|c|, n = c / |c|, friction = budget / |d|, collider velocity = s / h (after a
continuous move: no friction, and the velocity of the path x0 -> corrected end, as the
collider carried it).

Per step, for every free particle, with x0 the start position, v the candidate average
velocity (x1 - x0)/h from the solve, h the step:

1. repulsion, at the start positions: if x0 lies within the grown surface (collider margin
   plus the cloth's thickness), depth d = |push-out| > 0, and the relative normal velocity
   is v_r < 0.1 d / h, it gets the normal impulse I = min(h k d, m (0.1 d/h - v_r)) (the
   slide's cap; k = the cloth's stretch modulus);
2. friction with every normal impulse I: the relative tangential velocity v_T becomes
   max(1 - mu I / (m |v_T|), 0) v_T (Coulomb, static and kinetic with one mu);
3. inelastic impulses, at the end positions: a particle whose path x0 -> x0 + h v needs a
   correction c gets the velocity change c / h along n, which lands it on the surface
   instead of passing through (it stops on the collider rather than bouncing); friction as
   in 2. Repeated ``passes`` times, so a second collider is resolved too;
4. a final robust pass: the same correction once more, without friction.

The average velocity after 1-4 sets the new position x1 = x0 + h v; the velocity the
particle keeps gets the same impulses and then loses its inward relative normal component
along the last contact normal (a completely inelastic contact: the particle leaves the step
resting on the collider, not driving into it). The solver runs strain limiting between
steps 3 and 4 (then motion constraints), so that step 4 has the last word on positions.
"""

from __future__ import annotations

from numba import prange
from numba.extending import register_jitable as jitable

from clothtool._jit import kernel
from clothtool.integrators.implicit import vec
from clothtool.solver.kernels.collide import point_correction

# Contact decisions compare distances with margins exactly at the boundary (a resting
# particle sits at the margin); fused multiply-adds would flip some of them, so this module
# keeps plain IEEE arithmetic (its cost is small next to the conjugate-gradient solve).
EXACT = False

NO_CONTACT = 1e30  # phi of a particle that touches nothing
NEGLIGIBLE = 1e-7  # a correction shorter than this times (1 + |x|) is none
_NO_CONTACT = (NO_CONTACT, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@jitable
def _contact(shapes, mesh, frame, p0, p1, h, continuous):
    """The contact summary (phi, normal xyz, friction, collider velocity xyz) of the point
    moving p0 -> p1 over the step (module docstring), and its correction c (a 3-tuple)."""
    count, mx, my, mz, dx, dy, dz, sx, sy, sz, budget = point_correction(
        p1[0], p1[1], p1[2], p0[0], p0[1], p0[2], shapes, mesh, frame, continuous
    )
    c = (float(mx + dx), float(my + dy), float(mz + dz))
    size = vec.norm(c)
    # below the rounding of the (possibly float32) collider records: no contact, else its
    # noise normal would take the kept velocity's "inward" part away
    if size <= NEGLIGIBLE * (1.0 + max(abs(p1[0]), abs(p1[1]), abs(p1[2]))):
        return _NO_CONTACT, (0.0, 0.0, 0.0)
    n = vec.scale(1.0 / size, c)
    if mx == 0.0 and my == 0.0 and mz == 0.0:
        push = vec.norm((float(dx), float(dy), float(dz)))
        friction = float(budget) / push if push > 0.0 else 0.0
        velocity = (float(sx) / h, float(sy) / h, float(sz) / h)
    else:  # a continuous move: carried from the start to where it hit, without friction
        friction = 0.0
        velocity = vec.scale(1.0 / h, vec.sub(vec.add(p1, c), p0))
    return (-size, n[0], n[1], n[2], friction, velocity[0], velocity[1], velocity[2]), c


@jitable
def _impulse(v, dvn, contact):
    """v + dvn n, then Coulomb friction for that normal impulse (per unit mass) on the
    velocity relative to the collider."""
    n = (contact[1], contact[2], contact[3])
    friction = contact[4]
    vc = (contact[5], contact[6], contact[7])
    v = vec.axpy(dvn, n, v)
    rel = vec.sub(v, vc)
    tangent = vec.axpy(-vec.dot(rel, n), n, rel)
    speed = vec.norm(tangent)
    if speed > 0.0 and friction > 0.0 and dvn > 0.0:
        keep = max(1.0 - friction * dvn / speed, 0.0)
        v = vec.axpy(keep - 1.0, tangent, v)
    return v


@kernel(parallel=True, fastmath=EXACT)
def collide_particles(shapes, mesh, frame, x0, mass, free, stiffness, h, passes, v_mid, v_end, contact):
    """Bridson's steps 1-3 (module docstring) for every free particle.

    shapes, mesh, frame: the colliders posed for the step (``CollideStage.groups``); x0 (n,3)
    start positions; mass (n,); free u8 (n,); stiffness: repulsion spring k; passes: rounds
    of step 3. v_mid (n,3) in/out: the average velocity over the step (the new position is
    x0 + h v_mid); v_end (n,3) in/out: the velocity the particle keeps, changed by the same
    impulses; contact (n,8) out: the last contact that gave the particle an impulse (phi,
    normal, friction, collider velocity; phi = NO_CONTACT for none)."""
    for i in prange(x0.shape[0]):
        contact[i, 0] = NO_CONTACT
        if free[i] == 0:
            continue
        p0 = vec.row(x0, i)
        v = vec.row(v_mid, i)
        v_start = v
        m = mass[i]
        last = _NO_CONTACT
        # 1-2: repulsion within the grown surface at the start, with friction
        found, _ = _contact(shapes, mesh, frame, p0, p0, h, False)
        d = -found[0]
        if found[0] < NO_CONTACT:
            vr = vec.dot(vec.sub(v, (found[5], found[6], found[7])), (found[1], found[2], found[3]))
            if vr < 0.1 * d / h:
                dvn = min(h * stiffness * d / m, 0.1 * d / h - vr)
                v = _impulse(v, dvn, found)
                last = found
        # 3: inelastic impulses for what the paths to the end positions reach
        for _ in range(passes):
            found, c = _contact(shapes, mesh, frame, p0, vec.axpy(h, v, p0), h, True)
            if found[0] >= NO_CONTACT:
                break
            v = _impulse(v, -found[0] / h, found)
            last = found
        vec.set_row(v_mid, i, v)
        vec.add_row(v_end, i, 1.0, vec.sub(v, v_start))
        if last[0] < NO_CONTACT:
            for k in range(8):
                contact[i, k] = last[k]


@kernel(parallel=True, fastmath=EXACT)
def project_particles(shapes, mesh, frame, x0, free, h, v_mid, v_end, contact):
    """Bridson's step 4, the final robust pass, for every free particle: the path
    x0 -> x0 + h v_mid is corrected once more (onto the grown surface, on the side it came
    from). A particle that touches a collider (``contact`` from ``collide_particles``, or
    this pass) keeps a velocity v_end without inward relative normal part; ``contact`` (n,8)
    records this pass's contacts too."""
    for i in prange(x0.shape[0]):
        if free[i] == 0:
            continue
        p0 = vec.row(x0, i)
        v = vec.row(v_mid, i)
        found, c = _contact(shapes, mesh, frame, p0, vec.axpy(h, v, p0), h, True)
        if found[0] < NO_CONTACT:
            v = vec.axpy(1.0 / h, c, v)
            vec.set_row(v_mid, i, v)
            for k in range(8):
                contact[i, k] = found[k]
        if contact[i, 0] < NO_CONTACT:
            n = (contact[i, 1], contact[i, 2], contact[i, 3])
            keep = vec.row(v_end, i)
            inward = vec.dot(vec.sub(keep, (contact[i, 5], contact[i, 6], contact[i, 7])), n)
            if inward < 0.0:
                vec.set_row(v_end, i, vec.axpy(-inward, n, keep))
