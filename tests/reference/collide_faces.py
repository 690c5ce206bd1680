"""References for clothtool/solver/kernels/collide_faces.py, from the definition: a triangle's
deepest point against a sphere or capsule is found by searching the triangle (a barycentric
grid, then ever finer grids around the best point so far) for the least round-cone distance (clothtool.solver.penetration's numpy one);
the point then collides as the kernel module's docstring says. Nothing here follows the
kernel's candidates. Results are float64 copies; the inputs are left alone."""

from __future__ import annotations

import numpy as np

from clothtool.solver.penetration import barycentric_grid, round_cone_distance
from tests.reference.collide import friction_correction
from tests.reference.collide_mesh import closest_on_triangle

_OFFSETS = np.stack(np.meshgrid(np.arange(-10, 11), np.arange(-10, 11), indexing="ij"), -1).reshape(-1, 2).astype(np.float64)


# the largest share c w_i / sum(w^2) takes when all three corners move: by symmetry at equal
# other weights, the maximum of w / (w^2 + (1 - w)^2 / 2) over [0, 1], found numerically
_W = np.linspace(0.0, 1.0, 1000001)
_MOST = float(np.max(_W / (_W * _W + (1 - _W) ** 2 / 2)))


def hull_distance(points, a, ra, b, rb):
    """Signed distance of points (..., 3) to the hull of the spheres (a, ra), (b, rb):
    clothtool.solver.penetration's round cone, or the bigger sphere when it holds the other."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    if np.linalg.norm(b - a) <= abs(ra - rb):
        a, ra = (a, ra) if ra >= rb else (b, rb)
        b, rb = a, ra
    return round_cone_distance(points, a, b, np.float64(ra), np.float64(rb))


def deepest(corners, a, ra, b, rb) -> tuple[float, np.ndarray]:
    """(signed distance, barycentric weights (3,)) of the deepest point of the triangle
    ``corners`` (3,3) against the hull of the spheres (a, ra), (b, rb): the best point of a
    barycentric grid, then of ever finer 21 x 21 grids around the best so far (a grid, not a
    few directions: the distance is a cone, not smooth, where the axis crosses the triangle)."""
    corners = np.asarray(corners, np.float64)

    def distance(weights):
        return hull_distance(weights @ corners, a, ra, b, rb)

    grid = barycentric_grid(60)
    values = distance(grid)
    best, low = grid[int(np.argmin(values))], float(values.min())
    step = 1.0 / 60
    for _ in range(12):
        step /= 4.0
        uv = np.clip(best[1:] + step * _OFFSETS, 0.0, 1.0)
        uv /= np.maximum(uv.sum(axis=1, keepdims=True), 1.0)  # onto the triangle
        weights = np.column_stack([1.0 - uv.sum(axis=1), uv])
        values = distance(weights)
        k = int(np.argmin(values))
        if values[k] < low:
            best, low = weights[k], float(values[k])
    return low, best


def _capsule_terms(C, c):
    """Capsule c's end spheres and axis terms (columns 8-15 and 17-23) as a tuple."""
    row = np.asarray(C[c], np.float64)
    return (*row[8:16], *row[17:24])


def _side(t, rho2, T):
    """The cone's side distance cos(alpha) rho + sin(alpha) t - ra where the closest
    interpolated sphere's centre (at axial t - rho tan(alpha)) lies strictly inside the
    axis, else inf."""
    ra, length, sin_a, cos_a = T[3], T[11], T[12], T[13]
    rho = np.sqrt(rho2)
    centre = t - rho * sin_a / cos_a
    return cos_a * rho + sin_a * t - ra if 0.0 < centre < length else np.inf


def _edge_minimum(px, py, pz, qx, qy, qz, T):
    """(side distance, lambda): the least cos(alpha) rho + sin(alpha) t over the edge
    p + lambda (q - p), found by a bounded scalar search, and _side there."""
    from scipy.optimize import minimize_scalar

    a, u = np.asarray(T[0:3], np.float64), np.asarray(T[8:11], np.float64)
    p, q = np.array([px, py, pz], np.float64), np.array([qx, qy, qz], np.float64)
    sin_a, cos_a = T[12], T[13]

    def terms(lam):
        d = p + lam * (q - p) - a
        t = d @ u
        return t, d @ d - t * t

    def cone(lam):
        t, rho2 = terms(lam)
        return cos_a * np.sqrt(max(rho2, 0.0)) + sin_a * t

    grid = np.linspace(0.0, 1.0, 201)
    k = int(np.argmin([cone(x) for x in grid]))
    found = minimize_scalar(cone, bounds=(grid[max(k - 1, 0)], grid[min(k + 1, 200)]), method="bounded",
                            options={"xatol": 1e-12})
    lam = found.x if found.fun <= cone(grid[k]) else grid[k]
    t, rho2 = terms(lam)
    return _side(t, max(rho2, 0.0), T), lam


def _end_sphere(cx, cy, cz, r, p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z):
    """(|x - c| - r, weights of x) for the triangle's point x closest to c."""
    u, v = closest_on_triangle(cx, cy, cz, p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z)
    w = np.array([1.0 - u - v, u, v])
    x = w @ np.array([[p0x, p0y, p0z], [p1x, p1y, p1z], [p2x, p2y, p2z]], np.float64)
    return (float(np.linalg.norm(x - [cx, cy, cz])) - r, *w)


def _collider_boxes(sphere_data, capsule_data):
    """(s+c, 6) lo xyz, hi xyz: each sphere's and capsule's box at the end pose."""
    S, C = np.asarray(sphere_data, np.float64), np.asarray(capsule_data, np.float64)
    boxes = [np.concatenate([S[s, 4:7] - S[s, 7], S[s, 4:7] + S[s, 7]]) for s in range(S.shape[0])]
    for c in range(C.shape[0]):
        ends = np.array([C[c, 8:11], C[c, 12:15]])
        r = max(C[c, 11], C[c, 15])
        boxes.append(np.concatenate([ends.min(axis=0) - r, ends.max(axis=0) + r]))
    return np.array(boxes).reshape(-1, 6)


def _correct(cur, prev, a, b, c, wa, wb, wc, d, nx, ny, nz, sx, sy, sz, friction, mass_scale, meters_per_unit):
    """A copy of ``cur`` after the point w of triangle abc, -d inside along n on a surface that
    moved by s, is pushed out with friction and mass scale, its correction shared out as
    c w_i / sum(w^2) over the movable corners, a share never above the most it is when all
    three corners move."""
    cur = np.array(cur, np.float64)
    prev = np.asarray(prev, np.float64)
    face, w = [a, b, c], np.array([wa, wb, wc], np.float64)
    normal = np.array([nx, ny, nz], np.float64)
    p, q = w @ cur[face, :3], w @ prev[face, :3]
    push = -d * normal
    fx = friction_correction(*(p + push), *q, *push, sx, sy, sz, -friction * d)
    correction = push + np.asarray(fx)
    movable = (prev[face, 3] > 0) & (cur[face, 3] > 0)
    m = np.where(movable, w, 0.0)
    norm = m @ m
    if norm <= 0:
        return cur
    scale = 1.0 / (1.0 + mass_scale * (push @ push) * meters_per_unit ** 2) if mass_scale > 0 else 1.0
    for particle, weight in zip(face, m):
        if weight == 0:
            continue
        cur[particle, :3] += correction * min(weight / norm, _MOST)
        cur[particle, 3] *= 1.0 + (scale - 1.0) * weight
    return cur


def capsule_deepest(p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z, T, exact=True):
    """(g, wa, wb, wc): the least signed distance of the triangle p0 p1 p2 from the capsule of
    terms T (ax, ay, az, ra, bx, by, bz, rb, ...) and the barycentric weights of its point
    (always exact: the kernel's non-exact mode may only give inf where nothing is inside)."""
    corners = np.array([[p0x, p0y, p0z], [p1x, p1y, p1z], [p2x, p2y, p2z]], np.float64)
    d, w = deepest(corners, T[0:3], T[3], T[4:7], T[7])
    return (d, *w)


def collide_faces(faces, sphere_data, capsule_data, prev, mass_scale, meters_per_unit, cur):
    """Every face against every sphere, then every capsule, in order: the deepest point,
    when inside, pushed out to the surface with friction and mass scale, its correction
    shared out as c w_i / sum(w^2) over the movable corners, a share never above the most it
    is when all three corners move (max of w / (w^2 + (1 - w)^2 / 2), at w = 1/sqrt 3)."""
    cur = np.array(cur, np.float64)
    prev = np.asarray(prev, np.float64)
    S, C = np.asarray(sphere_data, np.float64), np.asarray(capsule_data, np.float64)
    colliders = [(S[s, 4:7], S[s, 7], S[s, 4:7], S[s, 7], S[s, 4:7] - S[s, 0:3], S[s, 4:7] - S[s, 0:3], S[s, 8])
                 for s in range(S.shape[0])]
    colliders += [(C[c, 8:11], C[c, 11], C[c, 12:15], C[c, 15], C[c, 8:11] - C[c, 0:3], C[c, 12:15] - C[c, 4:7], C[c, 16])
                  for c in range(C.shape[0])]
    for face in np.asarray(faces):
        for a, ra, b, rb, move_a, move_b, friction in colliders:
            d, w = deepest(cur[face, :3], a, ra, b, rb)
            if d >= 0.0:
                continue
            p = w @ cur[face, :3]
            eps = 1e-7 * max(1.0, float(np.abs(p).max()))  # the outward normal by central differences
            normal = np.array([
                hull_distance(p + eps * e, a, ra, b, rb) - hull_distance(p - eps * e, a, ra, b, rb) for e in np.eye(3)
            ]) / (2 * eps)
            normal /= np.linalg.norm(normal)
            # sigma: the interpolated sphere a + s (b - a), ra + s (rb - ra) whose surface holds the
            # closest point x = p - d n, its centre lying along -n from x (least squares in s)
            surface = p - d * normal
            axis = b - a
            if np.linalg.norm(axis) <= abs(ra - rb):  # one sphere holds the other: the bigger
                sigma = 0.0 if ra >= rb else 1.0
            else:
                along = axis + (rb - ra) * normal
                sigma = float(np.clip((surface - a - ra * normal) @ along / (along @ along), 0.0, 1.0))
            shift = (1 - sigma) * move_a + sigma * move_b
            cur = _correct(cur, prev, *face, *w, d, *normal, *shift, friction, mass_scale, meters_per_unit)
    return cur
