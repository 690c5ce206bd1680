"""Collisions after the position update: project out of the colliders, then fix the velocity.

For every movable particle (cur.w > 0) and every collider whose surface, grown by its margin
(collider thickness + cloth thickness), the particle is inside of:

* the particle moves to the closest point of the grown surface (along the outward normal n);
* its velocity relative to the collider's surface velocity v_c, r = v - v_c, loses its
  inward normal part (inelastic): with r_n = r . n < 0, the impulse per mass is -r_n;
* Coulomb friction: the tangential part r_t = r - r_n n shrinks by at most mu |r_n| (it stops
  when |r_t| <= mu |r_n|): r_t *= max(0, 1 - mu |r_n| / |r_t|);
* v = v_c + r_t, and prev = cur - h v, so that (cur - prev) / h stays the velocity.

A particle moving out of the collider (r_n >= 0) keeps its velocity. Colliders are handled
one after another in the order given, each seeing the positions the ones before it left.

Distance functions (world space, scene units):
* sphere (c, r): n = (x - c) / |x - c| (+Y at the centre), surface c + r n;
* tapered capsule: the union of the spheres (c0 + t (c1 - c0), r0 + t (r1 - r0)), t in
  [0, 1]; the distance |x - c(t)| - r(t) is convex in t and smallest at
  t* = (a - s p / sqrt(1 - s^2)) / L, clamped to [0, 1], with L = |c1 - c0|, a and p the
  particle's coordinates along and across the axis and s = (r0 - r1) / L (when one end
  sphere contains the other, |s| >= 1, the larger one is the capsule);
* convex (planes n . x = d, solid where n . x < d for all, normals not necessarily unit):
  inside when every normalised plane has n . x - d < margin; pushed out through the plane
  with the largest n . x - d (the least penetration);
* triangle mesh: per mesh, the closest triangle (Ericson's closest point, barycentric
  weights b); the side is the sign of (x - q) . n_face (outward by counter-clockwise winding),
  so a mesh is taken as the boundary of a solid; inside, or outside closer than the margin,
  the particle moves to q + margin * n (n = (x - q) / |x - q| outside, n_face inside).

Collider surface velocities: sphere c' + r' n; capsule the same at t*; plane n (d' - n' . x)
/ |n| (normal motion only); mesh b0 v_a + b1 v_b + b2 v_c.
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel

INF = np.float32(np.inf)


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
def collide_spheres(center, radius, center_velocity, radius_velocity, spheres, margin, friction, h, cur, prev, velocity):
    """center (s,3), radius (s,) and their rates (s,3), (s,); spheres (k,) the sphere
    colliders' indices; margin, friction (k,) per sphere collider (margin includes the
    cloth's thickness, friction is the combined coefficient); h: the step."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    for i in range(cur.shape[0]):
        if not cur[i, 3] > zero:
            continue
        for k in range(spheres.shape[0]):
            s = spheres[k]
            dx = cur[i, 0] - center[s, 0]
            dy = cur[i, 1] - center[s, 1]
            dz = cur[i, 2] - center[s, 2]
            dist = np.sqrt(dx * dx + dy * dy + dz * dz)
            reach = radius[s] + margin[k]
            if not dist < reach:
                continue
            nx, ny, nz = zero, one, zero
            if dist > zero:
                nx, ny, nz = dx / dist, dy / dist, dz / dist
            rate = radius_velocity[s]
            _respond(
                i, center[s, 0] + reach * nx, center[s, 1] + reach * ny, center[s, 2] + reach * nz, nx, ny, nz,
                center_velocity[s, 0] + rate * nx, center_velocity[s, 1] + rate * ny, center_velocity[s, 2] + rate * nz,
                friction[k], h, cur, prev, velocity,
            )


@kernel(inline="always")
def _capsule_parameter(ax, ay, az, px, py, pz, r0, r1):
    """t* in [0, 1] of the sphere of a tapered capsule closest to the point p (relative to
    the first centre), for the axis a = c1 - c0 and end radii r0, r1."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    length2 = ax * ax + ay * ay + az * az
    if length2 == zero:
        return zero if r0 >= r1 else one
    length = np.sqrt(length2)
    along = (px * ax + py * ay + pz * az) / length
    across = np.sqrt(max(zero, px * px + py * py + pz * pz - along * along))
    s = (r0 - r1) / length
    if s * s >= one:
        return zero if r0 >= r1 else one
    t = (along - s * across / np.sqrt(one - s * s)) / length
    return min(one, max(zero, t))


@kernel
def collide_capsules(center, radius, center_velocity, radius_velocity, capsules, margin, friction, h, cur, prev, velocity):
    """center, radius and rates as for spheres; capsules (c,2) the end spheres of each
    capsule; margin, friction (c,) per capsule."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    for i in range(cur.shape[0]):
        if not cur[i, 3] > zero:
            continue
        for k in range(capsules.shape[0]):
            s0 = capsules[k, 0]
            s1 = capsules[k, 1]
            r0 = radius[s0]
            r1 = radius[s1]
            t = _capsule_parameter(
                center[s1, 0] - center[s0, 0], center[s1, 1] - center[s0, 1], center[s1, 2] - center[s0, 2],
                cur[i, 0] - center[s0, 0], cur[i, 1] - center[s0, 1], cur[i, 2] - center[s0, 2], r0, r1,
            )
            u = one - t
            cx = u * center[s0, 0] + t * center[s1, 0]
            cy = u * center[s0, 1] + t * center[s1, 1]
            cz = u * center[s0, 2] + t * center[s1, 2]
            dx = cur[i, 0] - cx
            dy = cur[i, 1] - cy
            dz = cur[i, 2] - cz
            dist = np.sqrt(dx * dx + dy * dy + dz * dz)
            reach = u * r0 + t * r1 + margin[k]
            if not dist < reach:
                continue
            nx, ny, nz = zero, one, zero
            if dist > zero:
                nx, ny, nz = dx / dist, dy / dist, dz / dist
            rate = u * radius_velocity[s0] + t * radius_velocity[s1]
            _respond(
                i, cx + reach * nx, cy + reach * ny, cz + reach * nz, nx, ny, nz,
                u * center_velocity[s0, 0] + t * center_velocity[s1, 0] + rate * nx,
                u * center_velocity[s0, 1] + t * center_velocity[s1, 1] + rate * ny,
                u * center_velocity[s0, 2] + t * center_velocity[s1, 2] + rate * nz,
                friction[k], h, cur, prev, velocity,
            )


@kernel
def collide_convexes(plane, plane_velocity, offsets, margin, friction, h, cur, prev, velocity):
    """plane (p,4) (n, d), solid where n . x < d; plane_velocity (p,4) their rates;
    offsets (k+1,) CSR of each convex's planes; margin, friction (k,) per convex."""
    zero = np.float32(0.0)
    for i in range(cur.shape[0]):
        if not cur[i, 3] > zero:
            continue
        for k in range(offsets.shape[0] - 1):
            if offsets[k + 1] == offsets[k]:
                continue
            inside = True
            best = -INF
            best_p = offsets[k]
            for p in range(offsets[k], offsets[k + 1]):
                norm = np.sqrt(plane[p, 0] * plane[p, 0] + plane[p, 1] * plane[p, 1] + plane[p, 2] * plane[p, 2])
                gap = (plane[p, 0] * cur[i, 0] + plane[p, 1] * cur[i, 1] + plane[p, 2] * cur[i, 2] - plane[p, 3]) / norm
                gap -= margin[k]
                if not gap < zero:
                    inside = False
                    break
                if gap > best:
                    best = gap
                    best_p = p
            if not inside:
                continue
            p = best_p
            norm = np.sqrt(plane[p, 0] * plane[p, 0] + plane[p, 1] * plane[p, 1] + plane[p, 2] * plane[p, 2])
            nx = plane[p, 0] / norm
            ny = plane[p, 1] / norm
            nz = plane[p, 2] / norm
            speed = (
                plane_velocity[p, 3]
                - plane_velocity[p, 0] * cur[i, 0] - plane_velocity[p, 1] * cur[i, 1] - plane_velocity[p, 2] * cur[i, 2]
            ) / norm
            depth = -best
            _respond(
                i, cur[i, 0] + depth * nx, cur[i, 1] + depth * ny, cur[i, 2] + depth * nz, nx, ny, nz,
                speed * nx, speed * ny, speed * nz, friction[k], h, cur, prev, velocity,
            )


@kernel(inline="always")
def _closest_on_triangle(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Barycentric weights (wa, wb, wc) of the point of triangle abc closest to p
    (Ericson, Real-Time Collision Detection, 5.1.5: Voronoi regions of vertices, edges, face)."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= zero and d2 <= zero:
        return one, zero, zero
    bpx, bpy, bpz = px - bx, py - by, pz - bz
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= zero and d4 <= d3:
        return zero, one, zero
    vc = d1 * d4 - d3 * d2
    if vc <= zero and d1 >= zero and d3 <= zero:
        v = d1 / (d1 - d3) if d1 != d3 else zero
        return one - v, v, zero
    cpx, cpy, cpz = px - cx, py - cy, pz - cz
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= zero and d5 <= d6:
        return zero, zero, one
    vb = d5 * d2 - d1 * d6
    if vb <= zero and d2 >= zero and d6 <= zero:
        w = d2 / (d2 - d6) if d2 != d6 else zero
        return one - w, zero, w
    va = d3 * d6 - d5 * d4
    if va <= zero and d4 - d3 >= zero and d5 - d6 >= zero:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6)) if (d4 - d3) + (d5 - d6) != zero else zero
        return zero, one - w, w
    total = va + vb + vc
    if total == zero:
        return one, zero, zero
    v = vb / total
    w = vc / total
    return one - v - w, v, w


@kernel
def collide_triangles(points, point_velocity, triangles, offsets, margin, friction, h, cur, prev, velocity):
    """points, point_velocity (m,3); triangles (t,3) (counter-clockwise = outward); offsets
    (meshes+1,) CSR of each mesh's triangles; margin, friction (meshes,)."""
    zero = np.float32(0.0)
    for i in range(cur.shape[0]):
        if not cur[i, 3] > zero:
            continue
        for k in range(offsets.shape[0] - 1):
            px = cur[i, 0]
            py = cur[i, 1]
            pz = cur[i, 2]
            best = INF
            best_t = -1
            bw0 = bw1 = bw2 = zero
            for t in range(offsets[k], offsets[k + 1]):
                a = triangles[t, 0]
                b = triangles[t, 1]
                c = triangles[t, 2]
                w0, w1, w2 = _closest_on_triangle(
                    px, py, pz, points[a, 0], points[a, 1], points[a, 2], points[b, 0], points[b, 1], points[b, 2],
                    points[c, 0], points[c, 1], points[c, 2],
                )
                qx = w0 * points[a, 0] + w1 * points[b, 0] + w2 * points[c, 0]
                qy = w0 * points[a, 1] + w1 * points[b, 1] + w2 * points[c, 1]
                qz = w0 * points[a, 2] + w1 * points[b, 2] + w2 * points[c, 2]
                d2 = (px - qx) ** 2 + (py - qy) ** 2 + (pz - qz) ** 2
                if d2 < best:
                    best = d2
                    best_t = t
                    bw0, bw1, bw2 = w0, w1, w2
            if best_t < 0:
                continue
            a = triangles[best_t, 0]
            b = triangles[best_t, 1]
            c = triangles[best_t, 2]
            e1x, e1y, e1z = points[b, 0] - points[a, 0], points[b, 1] - points[a, 1], points[b, 2] - points[a, 2]
            e2x, e2y, e2z = points[c, 0] - points[a, 0], points[c, 1] - points[a, 1], points[c, 2] - points[a, 2]
            fx = e1y * e2z - e1z * e2y
            fy = e1z * e2x - e1x * e2z
            fz = e1x * e2y - e1y * e2x
            face = np.sqrt(fx * fx + fy * fy + fz * fz)
            if face == zero:
                continue
            fx /= face
            fy /= face
            fz /= face
            qx = bw0 * points[a, 0] + bw1 * points[b, 0] + bw2 * points[c, 0]
            qy = bw0 * points[a, 1] + bw1 * points[b, 1] + bw2 * points[c, 1]
            qz = bw0 * points[a, 2] + bw1 * points[b, 2] + bw2 * points[c, 2]
            dx, dy, dz = px - qx, py - qy, pz - qz
            dist = np.sqrt(dx * dx + dy * dy + dz * dz)
            outside = dx * fx + dy * fy + dz * fz > zero
            if outside and not dist < margin[k]:
                continue
            nx, ny, nz = fx, fy, fz
            if outside and dist > zero:
                nx, ny, nz = dx / dist, dy / dist, dz / dist
            m = margin[k]
            _respond(
                i, qx + m * nx, qy + m * ny, qz + m * nz, nx, ny, nz,
                bw0 * point_velocity[a, 0] + bw1 * point_velocity[b, 0] + bw2 * point_velocity[c, 0],
                bw0 * point_velocity[a, 1] + bw1 * point_velocity[b, 1] + bw2 * point_velocity[c, 1],
                bw0 * point_velocity[a, 2] + bw1 * point_velocity[b, 2] + bw2 * point_velocity[c, 2],
                friction[k], h, cur, prev, velocity,
            )
