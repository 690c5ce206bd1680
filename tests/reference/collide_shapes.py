"""References for clothtool/solver/kernels/collide_shapes.py, from the geometry.

A capsule is the convex hull of its two spheres. Its signed distance is computed from the
hull's support function h(n) = max(n.a + ra, n.b + rb): for a convex body the signed
distance of p is max over unit n of (n.p - h(n)), inside and outside alike, and the
maximising n is the outward normal at the closest surface point. By symmetry that n lies in
the half-plane of the axis and p, so a 1-d search over its angle (a dense grid, then a
bounded scalar minimisation) finds it. The times of impact are found by sampling the
distance along the motion and bisecting the first sign change, with the capsule taken as
the union of its interpolated spheres. Nothing here follows the kernels' algebra.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.spatial.transform import Rotation


def _vec(*xyz) -> np.ndarray:
    return np.asarray(xyz, np.float64)


def perpendicular(ux, uy, uz):
    u = _vec(ux, uy, uz)
    axis = np.zeros(3)
    axis[int(np.argmin(np.abs(u)))] = 1.0
    p = np.cross(u, axis)
    return tuple(p / np.linalg.norm(p))


def sphere_distance(px, py, pz, cx, cy, cz, radius):
    d = _vec(px, py, pz) - _vec(cx, cy, cz)
    length = np.linalg.norm(d)
    if length <= 1e-12:
        return -float(radius), 0.0, 1.0, 0.0
    return (length - radius, *(d / length))


def _hull(p, a, ra, b, rb):
    """(distance, normal) of p from the convex hull of the spheres (a, ra), (b, rb)."""
    axis = b - a
    length = np.linalg.norm(axis)
    u = axis / length if length > 0 else _vec(1.0, 0.0, 0.0)
    d = p - a
    axial = d @ u
    radial = d - axial * u
    rho = np.linalg.norm(radial)
    e = radial / rho if rho > 1e-12 * max(length, 1e-30) else _vec(*perpendicular(*u))

    def gap(theta):  # n(theta) . (p - a) - h(n(theta)) + n . a
        n = np.cos(theta) * u + np.sin(theta) * e
        return n @ d - max(ra, n @ axis + rb)

    grid = np.linspace(0.0, np.pi, 2001)
    normals = np.cos(grid)[:, None] * u + np.sin(grid)[:, None] * e
    values = normals @ d - np.maximum(ra, normals @ axis + rb)
    k = int(np.argmax(values))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    best = minimize_scalar(lambda t: -gap(t), bounds=(lo, hi), method="bounded", options={"xatol": 1e-13})
    theta = best.x if -best.fun >= values[k] else grid[k]
    return gap(theta), np.cos(theta) * u + np.sin(theta) * e


def round_cone_distance(px, py, pz, ax, ay, az, ra, bx, by, bz, rb):
    p, a, b = _vec(px, py, pz), _vec(ax, ay, az), _vec(bx, by, bz)
    distance, n = _hull(p, a, ra, b, rb)
    # sigma: the interpolated sphere a + s (b - a), ra + s (rb - ra) whose surface point along n
    # is the closest point x = p - distance n (least squares in s, then clamped)
    x = p - distance * n
    w = (b - a) + (rb - ra) * n
    r = x - a - ra * n
    sigma = float(np.clip((r @ w) / (w @ w), 0.0, 1.0)) if w @ w > 0 else 0.0
    if np.linalg.norm(b - a) <= abs(ra - rb):
        sigma = 0.0 if ra >= rb else 1.0
    return (distance, *n, sigma)


def _axial_and_radial(px, py, pz, ax, ay, az, ux, uy, uz):
    d, u = _vec(px, py, pz) - _vec(ax, ay, az), _vec(ux, uy, uz)
    axial = float(d @ u)
    e = d - axial * u
    return (axial, *e, float(e @ e))


def _cone_distance(px, py, pz, ax, ay, az, ra, bx, by, bz, rb, ux, uy, uz, length, sin_a, cos_a, axial, ex, ey, ez, radial2):
    return round_cone_distance(px, py, pz, ax, ay, az, ra, bx, by, bz, rb)


def capsule_axis(C, c):
    """Fill record c's end-pose axis terms (columns 17-23) from its end spheres."""
    from tests.reference.collide_pose import capsule_axes

    a, b = np.asarray(C[c:c + 1, 8:12], np.float64), np.asarray(C[c:c + 1, 12:16], np.float64)
    C[c, 17:24] = capsule_axes(a, b)[0]


def capsule_distance(px, py, pz, C, c):
    """round_cone_distance from capsule c's end pose; (inf, 0, 1, 0, 0) beyond 1.25 times the
    larger radius from the axis segment's slab or past an end (the terms of column 17-23)."""
    a, b = np.asarray(C[c, 8:11], np.float64), np.asarray(C[c, 12:15], np.float64)
    ra, rb = float(C[c, 11]), float(C[c, 15])
    reach = 1.25 * max(ra, rb)
    p = _vec(px, py, pz)
    length = np.linalg.norm(b - a)
    if length > abs(ra - rb) and length > 1e-12:
        u = (b - a) / length
        axial = (p - a) @ u
        radial = np.linalg.norm(p - a - axial * u)
        if radial > reach or axial < -reach or axial > length + reach:
            return np.inf, 0.0, 1.0, 0.0, 0.0
    return round_cone_distance(px, py, pz, *a, ra, *b, rb)


def convex_distance(px, py, pz, planes, first, last, margin):
    if last <= first:
        return np.inf, 0.0, 1.0, 0.0
    block = np.asarray(planes[first:last], np.float64)
    values = block[:, :3] @ _vec(px, py, pz) - block[:, 3] - margin
    k = int(np.argmax(values))
    return (values[k], *block[k, :3])


def _first_crossing(f, samples: int = 2001, vectorised: bool = False) -> float:
    """Earliest t in [0,1] with f(t) <= 0 (f sampled, then bisected), or -1."""
    if f(0.0) <= 0.0:
        return 0.0
    ts = np.linspace(0.0, 1.0, samples)
    values = f(ts) if vectorised else np.array([f(t) for t in ts])
    below = np.flatnonzero(values <= 0.0)
    if below.size == 0:
        return -1.0
    lo, hi = ts[below[0] - 1], ts[below[0]]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if f(mid) <= 0.0:
            hi = mid
        else:
            lo = mid
    return hi


def sphere_time_of_impact(qx, qy, qz, px, py, pz, c0x, c0y, c0z, r0, c1x, c1y, c1z, r1):
    q, p = _vec(qx, qy, qz), _vec(px, py, pz)
    c0, c1 = _vec(c0x, c0y, c0z), _vec(c1x, c1y, c1z)

    def gap(t):
        t = np.asarray(t, np.float64)[..., None]
        return np.linalg.norm(q + t * (p - q) - (c0 + t * (c1 - c0)), axis=-1) - (r0 + t[..., 0] * (r1 - r0))

    return float(_first_crossing(gap, vectorised=True))


def capsule_at(capsule_data, c, t):
    row = np.asarray(capsule_data[c], np.float64)
    return tuple((1.0 - t) * row[:8] + t * row[8:16])


def _union_gap(point, capsule) -> float:
    """min over the interpolated spheres of |point - centre| - radius (<= 0 inside)."""
    ax, ay, az, ra, bx, by, bz, rb = capsule
    s = np.linspace(0.0, 1.0, 1001)[:, None]
    centres = (1 - s) * _vec(ax, ay, az) + s * _vec(bx, by, bz)
    radii = (1 - s[:, 0]) * ra + s[:, 0] * rb
    return float(np.min(np.linalg.norm(point - centres, axis=1) - radii))


def capsule_time_of_impact(qx, qy, qz, px, py, pz, capsule_data, c):
    q, p = _vec(qx, qy, qz), _vec(px, py, pz)
    t = _first_crossing(lambda t: _union_gap(q + t * (p - q), capsule_at(capsule_data, c, t)), samples=401)
    if t < 0:
        return -1.0, 0.0, 0.0, 0.0, 0.0
    x = q + t * (p - q)
    _, nx, ny, nz, sigma = round_cone_distance(*x, *capsule_at(capsule_data, c, t))
    return t, nx, ny, nz, sigma


def rotate_between(ux, uy, uz, wx, wy, wz, x, y, z):
    u, w, v = _vec(ux, uy, uz), _vec(wx, wy, wz), _vec(x, y, z)
    cosine = float(np.clip(u @ w, -1.0, 1.0))
    axis = np.cross(u, w)
    if cosine <= -0.999 or np.linalg.norm(axis) < 1e-15:
        return tuple(v)
    rotation = Rotation.from_rotvec(axis / np.linalg.norm(axis) * np.arccos(cosine))
    return tuple(rotation.apply(v))
