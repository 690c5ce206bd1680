"""Reference for clothtool.integrators.implicit.collision, written from its docstrings with
independent geometry: the tapered capsule as the union of the spheres swept along its axis
(signed distance = min over t of |p - c(t)| - r(t), minimised numerically), triangles by
projection on the plane or onto the three edges, every mesh triangle tested (no grid).

A contact is (phi, normal xyz, friction, collider velocity xyz); phi = signed distance minus
the collider's margin, 1e30 without colliders.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize_scalar

NONE = (1e30, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def _contact(phi, n, friction, velocity):
    return (float(phi), *map(float, n), float(friction), *map(float, velocity))


def _segment_closest(p, a, b):
    ab = b - a
    t = np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0)
    return a + t * ab, t


def closest_on_triangle(p, a, b, c):
    """(closest point, barycentric weights) of triangle abc to p."""
    normal = np.cross(b - a, c - a)
    q = p - ((p - a) @ normal) / (normal @ normal) * normal
    area = normal @ normal
    wa = np.cross(b - q, c - q) @ normal / area
    wb = np.cross(c - q, a - q) @ normal / area
    wc = 1.0 - wa - wb
    if min(wa, wb, wc) >= 0:
        return q, np.array([wa, wb, wc])
    best = None
    for (u, v, iu, iv) in ((a, b, 0, 1), (b, c, 1, 2), (c, a, 2, 0)):
        point, t = _segment_closest(p, u, v)
        weights = np.zeros(3)
        weights[iu], weights[iv] = 1 - t, t
        if best is None or np.linalg.norm(p - point) < np.linalg.norm(p - best[0]):
            best = (point, weights)
    return best


def _rate(start, end, h):
    start, end = np.asarray(start, np.float64), np.asarray(end, np.float64)
    return (end - start) / h if start.shape == end.shape else np.zeros(end.shape)


def nearest_contact(start, end, h, p, at_end=True, mesh_radius=np.inf, only_mesh=False):
    """The nearest contact of point p among the colliders of ``end`` (or ``start`` when
    at_end is False), velocities from start to end over h. Mesh triangles count only within
    ``mesh_radius`` + margin of p (the kernel's grid radius); ``only_mesh``: ignore the
    other colliders."""
    arrays = end if at_end else start
    p = np.asarray(p, np.float64)
    centres = np.asarray(arrays.sphere_center, np.float64)
    radii = np.asarray(arrays.sphere_radius, np.float64)
    centre_rate = _rate(start.sphere_center, end.sphere_center, h)
    radius_rate = _rate(start.sphere_radius, end.sphere_radius, h)
    candidates = [NONE]
    for s in np.flatnonzero(arrays.sphere_is_collider) if not only_mesh else ():
        d = p - centres[s]
        n = d / np.linalg.norm(d)
        candidates.append(_contact(np.linalg.norm(d) - radii[s] - arrays.sphere_margin[s], n, arrays.sphere_friction[s],
                                   centre_rate[s] + radius_rate[s] * n))
    for j, (a, b) in enumerate(np.asarray(arrays.capsule_spheres) if not only_mesh else ()):

        def g(t, a=a, b=b):
            c = (1 - t) * centres[a] + t * centres[b]
            return np.linalg.norm(p - c) - ((1 - t) * radii[a] + t * radii[b])

        best = minimize_scalar(g, bounds=(0.0, 1.0), method="bounded", options={"xatol": 1e-12})
        t = min((0.0, 1.0, best.x), key=g)
        c = (1 - t) * centres[a] + t * centres[b]
        n = (p - c) / np.linalg.norm(p - c)
        velocity = (1 - t) * centre_rate[a] + t * centre_rate[b] + ((1 - t) * radius_rate[a] + t * radius_rate[b]) * n
        candidates.append(_contact(g(t) - arrays.capsule_margin[j], n, arrays.capsule_friction[j], velocity))
    planes = np.asarray(arrays.plane, np.float64)
    plane_rate = _rate(np.asarray(start.plane)[:, 3], np.asarray(end.plane)[:, 3], h)
    offsets = np.asarray(arrays.convex_plane_offsets)
    for k in range(offsets.shape[0] - 1 if not only_mesh else 0):
        rows = np.arange(offsets[k], offsets[k + 1])
        distances = planes[rows, :3] @ p - planes[rows, 3]
        q = rows[np.argmax(distances)]
        n = planes[q, :3]
        candidates.append(_contact(distances.max() - arrays.convex_margin[k], n, arrays.convex_friction[k], plane_rate[q] * n))
    points = np.asarray(arrays.mesh_points, np.float64)
    point_rate = _rate(start.mesh_points, end.mesh_points, h)
    best = None
    for t, tri in enumerate(np.asarray(arrays.mesh_triangles)):
        margin = arrays.mesh_margin[arrays.triangle_mesh[t]]
        q, weights = closest_on_triangle(p, *points[tri])
        distance = np.linalg.norm(p - q) - margin
        if distance > mesh_radius:
            continue
        face = np.cross(points[tri[1]] - points[tri[0]], points[tri[2]] - points[tri[0]])
        alignment = abs((p - q) @ face) / np.linalg.norm(face)
        # ties (a shared edge or corner): the face best aligned with p - q decides the side
        tie = 1e-12 * (1 + np.abs(p).sum())
        if best is None or distance < best[0] - tie or (distance <= best[0] + tie and alignment > best[4]):
            best = (distance, t, q, weights, alignment)
    if best is not None:
        _, t, q, weights, _ = best
        tri = np.asarray(arrays.mesh_triangles)[t]
        face = np.cross(points[tri[1]] - points[tri[0]], points[tri[2]] - points[tri[0]])
        face /= np.linalg.norm(face)
        d = p - q
        length = np.linalg.norm(d)
        n = d / length if length > 0 else face
        if d @ face < 0:
            n, length = -n, -length
        mesh = arrays.triangle_mesh[t]
        candidates.append(_contact(length - arrays.mesh_margin[mesh], n, arrays.mesh_friction[mesh], weights @ point_rate[tri]))
    return min(candidates, key=lambda c: c[0])


def _impulse(v, dvn, contact):
    n, friction, vc = np.array(contact[1:4]), contact[4], np.array(contact[5:8])
    v = v + dvn * n
    rel = v - vc
    tangent = rel - (rel @ n) * n
    speed = np.linalg.norm(tangent)
    if speed > 0 and friction > 0 and dvn > 0:
        v = v - (1 - max(1 - friction * dvn / speed, 0.0)) * tangent
    return v


def nearest_contacts(start, end, h, points, mesh_radius=np.inf):
    """(n,8) ``nearest_contact`` of every point, at the end geometry."""
    return np.array([nearest_contact(start, end, h, p, mesh_radius=mesh_radius) for p in points])


def mesh_crossing(arrays, p0, p1):
    """The deepest crossing of a mesh face from front to back on the path p0 -> p1: p1's
    distance to the face's plane minus the margin, with the face normal (velocity 0: the
    test's meshes stand still); NONE when the path crosses no face."""
    points = np.asarray(arrays.mesh_points, np.float64)
    best = NONE
    for t, tri in enumerate(np.asarray(arrays.mesh_triangles)):
        a, b, c = points[tri]
        face = np.cross(b - a, c - a)
        face /= np.linalg.norm(face)
        s0, s1 = (p0 - a) @ face, (p1 - a) @ face
        if not (s0 >= 0 > s1):
            continue
        hit = p0 + s0 / (s0 - s1) * (p1 - p0)
        q, _ = closest_on_triangle(hit, a, b, c)
        if np.linalg.norm(hit - q) > 1e-9:
            continue
        mesh = arrays.triangle_mesh[t]
        candidate = _contact(s1 - arrays.mesh_margin[mesh], face, arrays.mesh_friction[mesh], np.zeros(3))
        best = min(best, candidate, key=lambda c: c[0])
    return best


def end_contacts(start, end, h, start_points, end_points, mesh_radius=np.inf):
    """(n,8) per path: the contact nearest to its end, or a deeper mesh crossing."""
    return np.array([
        min(nearest_contact(start, end, h, p1, mesh_radius=mesh_radius), mesh_crossing(end, p0, p1), key=lambda c: c[0])
        for p0, p1 in zip(np.asarray(start_points, np.float64), np.asarray(end_points, np.float64))
    ])


def collide_particles(start, end, x0, mass, free, thickness, stiffness, h, passes, v_mid, v_end):
    """Steps 1-3 of the module docstring, for colliders without meshes (the crossing test is
    checked apart). Returns (v_mid, v_end, contact (n,8)) as new arrays; contact holds the
    last contact that gave an impulse, phi = 1e30 for none."""
    v_mid = np.array(v_mid, np.float64)
    v_end = np.array(v_end, np.float64)
    contacts = np.tile(np.array(NONE), (x0.shape[0], 1))
    for i in range(x0.shape[0]):
        if not free[i]:
            continue
        p0 = np.asarray(x0[i], np.float64)
        v = v_mid[i].copy()
        last = None
        contact = nearest_contact(start, end, h, p0, at_end=False)
        d = thickness - contact[0]
        if d > 0:
            vr = (v - np.array(contact[5:8])) @ np.array(contact[1:4])
            if vr < 0.1 * d / h:
                dvn = min(h * stiffness * d / mass[i], 0.1 * d / h - vr)
                v = _impulse(v, dvn, contact)
                last = contact
        for _ in range(passes):
            contact = nearest_contact(start, end, h, p0 + h * v)
            phi = contact[0] - thickness
            if phi >= 0:
                break
            v = _impulse(v, -phi / h, contact)
            last = contact
        v_end[i] += v - v_mid[i]
        v_mid[i] = v
        if last is not None:
            contacts[i] = last
    return v_mid, v_end, contacts


def project_particles(start, end, x0, free, thickness, h, v_mid, v_end, contact):
    """Step 4: end positions within the thickness go onto the surface; a particle with a
    contact (from steps 1-3 or this one) keeps no inward relative normal velocity. Returns
    (v_mid, v_end, contact) as new arrays."""
    v_mid = np.array(v_mid, np.float64)
    v_end = np.array(v_end, np.float64)
    contact = np.array(contact, np.float64)
    for i in range(x0.shape[0]):
        if not free[i]:
            continue
        found = nearest_contact(start, end, h, np.asarray(x0[i], np.float64) + h * v_mid[i])
        phi = found[0] - thickness
        if phi < 0:
            v_mid[i] = v_mid[i] - phi / h * np.array(found[1:4])
            contact[i] = found
        if contact[i, 0] < 1e30:
            n, vc = contact[i, 1:4], contact[i, 5:8]
            inward = (v_end[i] - vc) @ n
            if inward < 0:
                v_end[i] = v_end[i] - inward * n
    return v_mid, v_end, contact
