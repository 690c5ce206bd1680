"""Reference for clothtool.integrators.explicit.kernels.explicit_collide (from its docstring).

Every movable particle (cur.w > 0), collider by collider in the given order: when it lies
inside the collider's surface grown by the margin it moves to the closest point of the grown
surface, loses its inward velocity relative to the surface (inelastic), has its tangential
velocity reduced by Coulomb friction mu |v_n| (to zero at most), and gets prev = x - h v.

The geometry is computed independently of the kernel's closed forms where one exists:
the tapered capsule's closest sphere by a golden-section search of the convex function
t -> |x - c(t)| - r(t), the closest point of a triangle from the face projection or the three
edges. Plain loops (the order matters when colliders overlap); float64 throughout.
"""

from __future__ import annotations

import math

import numpy as np

UP = np.array([0.0, 1.0, 0.0])


def _respond(i, target, normal, surface_velocity, mu, h, cur, prev, velocity):
    """Apply one contact to particle i in place (float64 arrays): move to ``target``, remove
    the inward relative normal velocity, Coulomb friction, prev = x - h v."""
    cur[i, :3] = target
    r = velocity[i] - surface_velocity
    rn = float(r @ normal)
    if rn < 0.0:
        tangent = r - rn * normal
        slide = float(np.linalg.norm(tangent))
        keep = max(0.0, 1.0 - mu * abs(rn) / slide) if slide > 0.0 else 0.0
        velocity[i] = surface_velocity + keep * tangent
    prev[i, :3] = cur[i, :3] - h * velocity[i]


def _copies(cur, prev, velocity):
    return np.array(cur, np.float64), np.array(prev, np.float64), np.array(velocity, np.float64)


def _unit(d):
    length = float(np.linalg.norm(d))
    return (d / length, length) if length > 0.0 else (UP.copy(), 0.0)


def collide_spheres(center, radius, center_velocity, radius_velocity, spheres, margin, friction, h, cur, prev, velocity):
    cur, prev, velocity = _copies(cur, prev, velocity)
    center = np.asarray(center, np.float64)
    for i in range(cur.shape[0]):
        if not cur[i, 3] > 0:
            continue
        for k, s in enumerate(np.asarray(spheres)):
            n, dist = _unit(cur[i, :3] - center[s])
            reach = float(radius[s]) + float(margin[k])
            if dist < reach:
                surface = np.asarray(center_velocity[s], np.float64) + float(radius_velocity[s]) * n
                _respond(i, center[s] + reach * n, n, surface, float(friction[k]), float(h), cur, prev, velocity)
    return cur, prev, velocity


def _capsule_parameter(ax, ay, az, px, py, pz, r0, r1):
    """argmin over t in [0,1] of |p - t a| - (r0 + t (r1 - r0)) by golden-section search."""
    a = np.array([ax, ay, az], np.float64)
    p = np.array([px, py, pz], np.float64)
    r0, r1 = float(r0), float(r1)

    def f(t):
        return float(np.linalg.norm(p - t * a)) - (r0 + t * (r1 - r0))

    lo, hi = 0.0, 1.0
    g = (math.sqrt(5.0) - 1.0) / 2.0
    for _ in range(80):
        m1, m2 = hi - g * (hi - lo), lo + g * (hi - lo)
        if f(m1) <= f(m2):
            hi = m2
        else:
            lo = m1
    return 0.5 * (lo + hi)


def collide_capsules(center, radius, center_velocity, radius_velocity, capsules, margin, friction, h, cur, prev, velocity):
    cur, prev, velocity = _copies(cur, prev, velocity)
    center = np.asarray(center, np.float64)
    center_velocity = np.asarray(center_velocity, np.float64)
    for i in range(cur.shape[0]):
        if not cur[i, 3] > 0:
            continue
        for k, (s0, s1) in enumerate(np.asarray(capsules)):
            r0, r1 = float(radius[s0]), float(radius[s1])
            t = _capsule_parameter(*(center[s1] - center[s0]), *(cur[i, :3] - center[s0]), r0, r1)
            c = (1 - t) * center[s0] + t * center[s1]
            n, dist = _unit(cur[i, :3] - c)
            reach = (1 - t) * r0 + t * r1 + float(margin[k])
            if dist < reach:
                rate = (1 - t) * float(radius_velocity[s0]) + t * float(radius_velocity[s1])
                surface = (1 - t) * center_velocity[s0] + t * center_velocity[s1] + rate * n
                _respond(i, c + reach * n, n, surface, float(friction[k]), float(h), cur, prev, velocity)
    return cur, prev, velocity


def collide_convexes(plane, plane_velocity, offsets, margin, friction, h, cur, prev, velocity):
    cur, prev, velocity = _copies(cur, prev, velocity)
    plane = np.asarray(plane, np.float64)
    plane_velocity = np.asarray(plane_velocity, np.float64)
    offsets = np.asarray(offsets)
    for i in range(cur.shape[0]):
        if not cur[i, 3] > 0:
            continue
        for k in range(offsets.shape[0] - 1):
            rows = range(offsets[k], offsets[k + 1])
            if not len(rows):
                continue
            x = cur[i, :3]
            norms = [float(np.linalg.norm(plane[p, :3])) for p in rows]
            gaps = [(plane[p, :3] @ x - plane[p, 3]) / nrm - float(margin[k]) for p, nrm in zip(rows, norms)]
            if max(gaps) >= 0.0:
                continue
            j = int(np.argmax(gaps))
            p, nrm = rows[j], norms[j]
            n = plane[p, :3] / nrm
            speed = (plane_velocity[p, 3] - plane_velocity[p, :3] @ x) / nrm
            _respond(i, x - gaps[j] * n, n, speed * n, float(friction[k]), float(h), cur, prev, velocity)
    return cur, prev, velocity


def _closest_on_segment(p, a, b):
    ab = b - a
    denominator = float(ab @ ab)
    t = 0.0 if denominator == 0.0 else min(1.0, max(0.0, float((p - a) @ ab) / denominator))
    return t


def _closest_on_triangle(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Barycentric weights of the closest point: the projection onto the plane when it falls
    inside the triangle, else the closest of the three edges' closest points."""
    p, a, b, c = (np.array(v, np.float64) for v in ((px, py, pz), (ax, ay, az), (bx, by, bz), (cx, cy, cz)))
    normal = np.cross(b - a, c - a)
    area2 = float(normal @ normal)
    if area2 > 0.0:
        q = p - (float((p - a) @ normal) / area2) * normal
        wa = float(np.cross(b - q, c - q) @ normal) / area2
        wb = float(np.cross(c - q, a - q) @ normal) / area2
        wc = 1.0 - wa - wb
        if wa >= 0.0 and wb >= 0.0 and wc >= 0.0:
            return wa, wb, wc
    best, weights = math.inf, (1.0, 0.0, 0.0)
    for (u, v, iu, iv) in ((a, b, 0, 1), (b, c, 1, 2), (a, c, 0, 2)):
        t = _closest_on_segment(p, u, v)
        q = (1 - t) * u + t * v
        d = float(np.linalg.norm(p - q))
        if d < best:
            w = [0.0, 0.0, 0.0]
            w[iu], w[iv] = 1 - t, t
            best, weights = d, tuple(w)
    return weights


def collide_triangles(points, point_velocity, triangles, offsets, margin, friction, h, cur, prev, velocity):
    cur, prev, velocity = _copies(cur, prev, velocity)
    points = np.asarray(points, np.float64)
    point_velocity = np.asarray(point_velocity, np.float64)
    triangles = np.asarray(triangles)
    offsets = np.asarray(offsets)
    for i in range(cur.shape[0]):
        if not cur[i, 3] > 0:
            continue
        for k in range(offsets.shape[0] - 1):
            x = cur[i, :3].copy()
            best, found = math.inf, None
            for t in range(offsets[k], offsets[k + 1]):
                corners = points[triangles[t]]
                w = np.array(_closest_on_triangle(*x, *corners[0], *corners[1], *corners[2]))
                q = w @ corners
                d = float(np.linalg.norm(x - q))
                if d < best:
                    best, found = d, (t, w, q)
            if found is None:
                continue
            t, w, q = found
            corners = points[triangles[t]]
            face = np.cross(corners[1] - corners[0], corners[2] - corners[0])
            if not np.linalg.norm(face) > 0:
                continue
            face = face / np.linalg.norm(face)
            outside = float((x - q) @ face) > 0.0
            m = float(margin[k])
            if outside and best >= m:
                continue
            n = (x - q) / best if outside and best > 0 else face
            surface = w @ point_velocity[triangles[t]]
            _respond(i, q + m * n, n, surface, float(friction[k]), float(h), cur, prev, velocity)
    return cur, prev, velocity
