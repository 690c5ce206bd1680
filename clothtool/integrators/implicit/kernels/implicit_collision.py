"""Collision kernels of the implicit integrator: distances to the colliders of a
``clothtool.integrators.implicit.collision.ColliderSet`` and Bridson's impulses (that
module's docstring describes the method). Helpers (``_name``) are ``register_jitable``
pieces of the kernels, checked through them."""

from __future__ import annotations

import math

from numba import prange
from numba.extending import register_jitable as jitable

from clothtool._jit import kernel

# Contact decisions compare distances with margins exactly at the boundary (a resting
# particle sits at the margin); fused multiply-adds would flip some of them, so this module
# keeps plain IEEE arithmetic (its cost is small next to the conjugate-gradient solve).
EXACT = False
from clothtool.integrators.implicit import vec

NO_CONTACT = 1e30  # phi of a particle that touches nothing
_FAR = NO_CONTACT


# ----------------------------------------------------------------- distances
# A contact is an 8-tuple: (phi, normal xyz, friction, collider velocity xyz).
_NO_CONTACT = (_FAR, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@jitable
def _contact(phi, n, friction, velocity):
    return (phi, n[0], n[1], n[2], friction, velocity[0], velocity[1], velocity[2])


@jitable
def _nearer(a, b):
    return b if b[0] < a[0] else a


@jitable
def _closest_on_triangle(p, a, b, c):
    """Barycentric weights (wa, wb, wc) of the point of triangle abc closest to p
    (Ericson, Real-Time Collision Detection, 5.1.5)."""
    ab = vec.sub(b, a)
    ac = vec.sub(c, a)
    ap = vec.sub(p, a)
    d1 = vec.dot(ab, ap)
    d2 = vec.dot(ac, ap)
    if d1 <= 0.0 and d2 <= 0.0:
        return 1.0, 0.0, 0.0
    bp = vec.sub(p, b)
    d3 = vec.dot(ab, bp)
    d4 = vec.dot(ac, bp)
    if d3 >= 0.0 and d4 <= d3:
        return 0.0, 1.0, 0.0
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        t = d1 / (d1 - d3)
        return 1.0 - t, t, 0.0
    cp = vec.sub(p, c)
    d5 = vec.dot(ab, cp)
    d6 = vec.dot(ac, cp)
    if d6 >= 0.0 and d5 <= d6:
        return 0.0, 0.0, 1.0
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        t = d2 / (d2 - d6)
        return 1.0 - t, 0.0, t
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return 0.0, 1.0 - t, t
    denom = 1.0 / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    return 1.0 - v - w, v, w


@jitable
def _blend(wa, a, wb, b, wc, c):
    return vec.axpy(wa, a, vec.axpy(wb, b, vec.scale(wc, c)))


@jitable
def _sphere_contact(center, radius, velocity, p, margin, friction):
    """velocity: (vx, vy, vz, dr/dt) of the sphere."""
    d = vec.sub(p, center)
    length = vec.norm(d)
    n = vec.scale(1.0 / length, d) if length > 0.0 else (0.0, 1.0, 0.0)
    surface_velocity = vec.axpy(velocity[3], n, (velocity[0], velocity[1], velocity[2]))
    return _contact(length - radius - margin, n, friction, surface_velocity)


@jitable
def _sphere_row(cs, s):
    return (cs.sphere[s, 0], cs.sphere[s, 1], cs.sphere[s, 2]), cs.sphere[s, 3], (
        cs.sphere_velocity[s, 0], cs.sphere_velocity[s, 1], cs.sphere_velocity[s, 2], cs.sphere_velocity[s, 3])


@jitable
def _capsule_contact(cs, j, p):
    """Exact distance to the tapered capsule j (the convex hull of its two spheres)."""
    a = cs.capsule[j, 0]
    b = cs.capsule[j, 1]
    margin = cs.capsule_margin[j]
    friction = cs.capsule_friction[j]
    c0, r0, v0 = _sphere_row(cs, a)
    c1, r1, v1 = _sphere_row(cs, b)
    axis = vec.sub(c1, c0)
    length = vec.norm(axis)
    if length <= abs(r0 - r1):  # one sphere holds the other: the larger one is the capsule
        if r0 >= r1:
            return _sphere_contact(c0, r0, v0, p, margin, friction)
        return _sphere_contact(c1, r1, v1, p, margin, friction)
    unit = vec.scale(1.0 / length, axis)
    d = vec.sub(p, c0)
    x = vec.dot(d, unit)
    radial = vec.axpy(-x, unit, d)
    y = vec.norm(radial)
    if y > 0.0:
        out = vec.scale(1.0 / y, radial)
    else:  # on the axis: any perpendicular
        helper = (1.0, 0.0, 0.0) if abs(unit[0]) < 0.9 else (0.0, 1.0, 0.0)
        out = vec.axpy(-vec.dot(helper, unit), unit, helper)
        out = vec.scale(1.0 / vec.norm(out), out)
    s = (r0 - r1) / length  # sine of the cone's half angle
    c = math.sqrt(1.0 - s * s)
    along = x * c - y * s  # along the tangent line, from sphere a's tangent point
    if along <= 0.0:
        return _sphere_contact(c0, r0, v0, p, margin, friction)
    if along >= length * c:
        return _sphere_contact(c1, r1, v1, p, margin, friction)
    n = vec.axpy(s, unit, vec.scale(c, out))
    tau = along / (length * c)
    radius_rate = (1.0 - tau) * v0[3] + tau * v1[3]
    centre_velocity = vec.axpy(1.0 - tau, (v0[0], v0[1], v0[2]), vec.scale(tau, (v1[0], v1[1], v1[2])))
    return _contact(x * s + y * c - r0 - margin, n, friction, vec.axpy(radius_rate, n, centre_velocity))


@jitable
def _convex_contact(cs, k, p):
    phi = -_FAR
    plane = -1
    for q in range(cs.convex_offsets[k], cs.convex_offsets[k + 1]):
        d = cs.plane[q, 0] * p[0] + cs.plane[q, 1] * p[1] + cs.plane[q, 2] * p[2] - cs.plane[q, 3]
        if d > phi:
            phi = d
            plane = q
    if plane < 0:
        return _NO_CONTACT
    n = (cs.plane[plane, 0], cs.plane[plane, 1], cs.plane[plane, 2])
    return _contact(phi - cs.convex_margin[k], n, cs.convex_friction[k], vec.scale(cs.plane_rate[plane], n))


@jitable
def _cell_bounds(low, high, geometry, shape):
    """Inclusive cell ranges (i0, i1, j0, j1, k0, k1) covering the box [low, high]; empty
    (i0 > i1) when it misses the grid."""
    i0 = i1 = j0 = j1 = k0 = k1 = 0
    for a in range(3):
        lo = int(math.floor((low[a] - geometry[a]) / geometry[3]))
        hi = int(math.floor((high[a] - geometry[a]) / geometry[3]))
        if hi < 0 or lo > shape[a] - 1:
            return 1, 0, 1, 0, 1, 0
        lo = min(max(lo, 0), shape[a] - 1)
        hi = min(max(hi, 0), shape[a] - 1)
        if a == 0:
            i0, i1 = lo, hi
        elif a == 1:
            j0, j1 = lo, hi
        else:
            k0, k1 = lo, hi
    return i0, i1, j0, j1, k0, k1


@jitable
def _mesh_triangle(cs, t):
    i, j, k = cs.mesh_triangles[t, 0], cs.mesh_triangles[t, 1], cs.mesh_triangles[t, 2]
    return (i, j, k), vec.row(cs.mesh_points, i), vec.row(cs.mesh_points, j), vec.row(cs.mesh_points, k)


@jitable
def _face_normal(a, b, c):
    face = vec.cross(vec.sub(b, a), vec.sub(c, a))
    length = vec.norm(face)
    return vec.scale(1.0 / length, face) if length > 0.0 else (0.0, 0.0, 0.0)


@jitable
def _mesh_contact(cs, p):
    """Nearest mesh triangle among those gridded into p's cell. When the nearest point is on
    an edge or a corner shared by several triangles, the one whose face normal is best
    aligned with p - q (largest |(p - q) . n|) decides inside or outside."""
    if cs.mesh_triangles.shape[0] == 0:
        return _NO_CONTACT
    i0, i1, j0, j1, k0, k1 = _cell_bounds(p, p, cs.grid_geometry, cs.grid_shape)
    if i0 > i1:
        return _NO_CONTACT
    cell = (i0 * cs.grid_shape[1] + j0) * cs.grid_shape[2] + k0
    best_distance = _FAR
    best_alignment = -1.0
    best_t = -1
    tie = 1e-12 * (1.0 + abs(p[0]) + abs(p[1]) + abs(p[2]))
    for slot in range(cs.cell_start[cell], cs.cell_start[cell + 1]):
        t = cs.cell_items[slot]
        _, a, b, c = _mesh_triangle(cs, t)
        wa, wb, wc = _closest_on_triangle(p, a, b, c)
        d = vec.sub(p, _blend(wa, a, wb, b, wc, c))
        distance = vec.norm(d) - cs.triangle_margin[t]
        alignment = abs(vec.dot(d, _face_normal(a, b, c)))
        if distance < best_distance - tie or (distance <= best_distance + tie and alignment > best_alignment):
            best_distance = distance
            best_alignment = alignment
            best_t = t
    if best_t < 0:
        return _NO_CONTACT
    ids, a, b, c = _mesh_triangle(cs, best_t)
    face = _face_normal(a, b, c)
    if face[0] == 0.0 and face[1] == 0.0 and face[2] == 0.0:
        return _NO_CONTACT
    wa, wb, wc = _closest_on_triangle(p, a, b, c)
    d = vec.sub(p, _blend(wa, a, wb, b, wc, c))
    length = vec.norm(d)
    if length > tie:
        n = vec.scale(1.0 / length, d)
        if vec.dot(d, face) < 0.0:
            n = vec.scale(-1.0, n)
            length = -length
    else:
        n = face
        length = 0.0
    velocity = _blend(wa, vec.row(cs.mesh_velocity, ids[0]), wb, vec.row(cs.mesh_velocity, ids[1]),
                      wc, vec.row(cs.mesh_velocity, ids[2]))
    return _contact(length - cs.triangle_margin[best_t], n, cs.triangle_friction[best_t], velocity)


@jitable
def _mesh_crossing(cs, p0, p1):
    """The deepest crossing of a mesh face from its front to its back on the path p0 -> p1:
    phi = p1's distance to the face's plane (negative) minus the margin, normal = the face's."""
    best = _NO_CONTACT
    if cs.mesh_triangles.shape[0] == 0:
        return best
    low = (min(p0[0], p1[0]), min(p0[1], p1[1]), min(p0[2], p1[2]))
    high = (max(p0[0], p1[0]), max(p0[1], p1[1]), max(p0[2], p1[2]))
    i0, i1, j0, j1, k0, k1 = _cell_bounds(low, high, cs.grid_geometry, cs.grid_shape)
    for ci in range(i0, i1 + 1):
        for cj in range(j0, j1 + 1):
            for ck in range(k0, k1 + 1):
                cell = (ci * cs.grid_shape[1] + cj) * cs.grid_shape[2] + ck
                for slot in range(cs.cell_start[cell], cs.cell_start[cell + 1]):
                    t = cs.cell_items[slot]
                    ids, a, b, c = _mesh_triangle(cs, t)
                    face = vec.cross(vec.sub(b, a), vec.sub(c, a))
                    face_length = vec.norm(face)
                    if face_length == 0.0:
                        continue
                    face = vec.scale(1.0 / face_length, face)
                    s0 = vec.dot(vec.sub(p0, a), face)
                    s1 = vec.dot(vec.sub(p1, a), face)
                    if not (s0 >= 0.0 and s1 < 0.0):
                        continue
                    hit = vec.axpy(s0 / (s0 - s1), vec.sub(p1, p0), p0)
                    wa, wb, wc = _closest_on_triangle(hit, a, b, c)
                    miss = vec.sub(hit, _blend(wa, a, wb, b, wc, c))
                    if vec.dot(miss, miss) > 1e-20 * (1.0 + vec.dot(hit, hit)):
                        continue
                    velocity = _blend(wa, vec.row(cs.mesh_velocity, ids[0]), wb, vec.row(cs.mesh_velocity, ids[1]),
                                      wc, vec.row(cs.mesh_velocity, ids[2]))
                    best = _nearer(best, _contact(s1 - cs.triangle_margin[t], face, cs.triangle_friction[t], velocity))
    return best


@jitable
def _nearest_contact(cs, p):
    """(phi, normal xyz, friction, collider velocity xyz) of the collider surface nearest to
    the point p (a tuple): phi = signed distance - margin, 1e30 when there is no collider."""
    best = _NO_CONTACT
    for s in range(cs.sphere.shape[0]):
        if cs.sphere_active[s]:
            centre, radius, velocity = _sphere_row(cs, s)
            best = _nearer(best, _sphere_contact(centre, radius, velocity, p, cs.sphere_margin[s], cs.sphere_friction[s]))
    for j in range(cs.capsule.shape[0]):
        best = _nearer(best, _capsule_contact(cs, j, p))
    for k in range(cs.convex_offsets.shape[0] - 1):
        best = _nearer(best, _convex_contact(cs, k, p))
    return _nearer(best, _mesh_contact(cs, p))


@jitable
def _end_contact(cs, p0, p1):
    """``_nearest_contact`` of p1, or a deeper mesh crossing on the path p0 -> p1."""
    return _nearer(_nearest_contact(cs, p1), _mesh_crossing(cs, p0, p1))


@kernel(fastmath=EXACT)
def nearest_contacts(cs, points, out):
    """out (n,8): the contact nearest to every row of points (n,3): (phi, normal xyz,
    friction, collider velocity xyz), phi = signed distance - margin (NO_CONTACT: none)."""
    for i in range(points.shape[0]):
        contact = _nearest_contact(cs, vec.row(points, i))
        for k in range(8):
            out[i, k] = contact[k]


# ----------------------------------------------------------------- response (numba)
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
def collide_particles(start, end, x0, mass, free, thickness, stiffness, h, passes, v_mid, v_end, contact):
    """Bridson's steps 1-3 (module docstring) for every free particle.

    start, end: ``ColliderSet`` at the step's start and end; x0 (n,3) start positions;
    mass (n,); free u8 (n,); thickness: the cloth's; stiffness: repulsion spring k;
    passes: rounds of step 3. v_mid (n,3) in/out: the average velocity over the step (the
    new position is x0 + h v_mid); v_end (n,3) in/out: the velocity the particle keeps,
    changed by the same impulses; contact (n,8) out: the last contact that gave the particle
    an impulse (phi, normal, friction, collider velocity; phi = NO_CONTACT for none)."""
    for i in prange(x0.shape[0]):
        contact[i, 0] = _FAR
        if free[i] == 0:
            continue
        p0 = vec.row(x0, i)
        v = vec.row(v_mid, i)
        v_start = v
        m = mass[i]
        last = _NO_CONTACT
        # 1-2: repulsion within the thickness at the start, with friction
        found = _nearest_contact(start, p0)
        d = thickness - found[0]
        if d > 0.0:
            vr = vec.dot(vec.sub(v, (found[5], found[6], found[7])), (found[1], found[2], found[3]))
            if vr < 0.1 * d / h:
                dvn = min(h * stiffness * d / m, 0.1 * d / h - vr)
                v = _impulse(v, dvn, found)
                last = found
        # 3: inelastic impulses for what the end positions reach
        for _ in range(passes):
            found = _end_contact(end, p0, vec.axpy(h, v, p0))
            phi = found[0] - thickness
            if phi >= 0.0:
                break
            v = _impulse(v, -phi / h, found)
            last = found
        vec.set_row(v_mid, i, v)
        vec.add_row(v_end, i, 1.0, vec.sub(v, v_start))
        if last[0] < _FAR:
            for k in range(8):
                contact[i, k] = last[k]


@kernel(parallel=True, fastmath=EXACT)
def project_particles(end, x0, free, thickness, h, v_mid, v_end, contact):
    """Bridson's step 4, the final robust pass, for every free particle: an end position
    x0 + h v_mid within the thickness of a collider is moved onto the surface (+ thickness)
    along the normal. A particle that touches a collider (``contact`` from
    ``collide_particles``, or this pass) keeps a velocity v_end without inward relative
    normal part; ``contact`` (n,8) records this pass's contacts too."""
    for i in prange(x0.shape[0]):
        if free[i] == 0:
            continue
        p0 = vec.row(x0, i)
        v = vec.row(v_mid, i)
        found = _end_contact(end, p0, vec.axpy(h, v, p0))
        phi = found[0] - thickness
        if phi < 0.0:
            v = vec.axpy(-phi / h, (found[1], found[2], found[3]), v)
            vec.set_row(v_mid, i, v)
            for k in range(8):
                contact[i, k] = found[k]
        if contact[i, 0] < _FAR:
            n = (contact[i, 1], contact[i, 2], contact[i, 3])
            keep = vec.row(v_end, i)
            inward = vec.dot(vec.sub(keep, (contact[i, 5], contact[i, 6], contact[i, 7])), n)
            if inward < 0.0:
                vec.set_row(v_end, i, vec.axpy(-inward, n, keep))


@kernel(fastmath=EXACT)
def end_contacts(cs, start_points, end_points, out):
    """out (n,8): for each path start -> end (rows of (n,3) arrays), the contact nearest to
    its end, or a deeper crossing of a mesh face from front to back on the way."""
    for i in range(start_points.shape[0]):
        contact = _end_contact(cs, vec.row(start_points, i), vec.row(end_points, i))
        for k in range(8):
            out[i, k] = contact[k]
