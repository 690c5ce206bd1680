"""References for clothtool/solver/kernels/collide_faces.py, from the definition: a triangle's
deepest point against a sphere or capsule is found by searching the triangle (a barycentric
grid, then ever finer grids around the best point so far) for the least round-cone distance (clothtool.solver.penetration's numpy one);
the point then collides as the kernel module's docstring says. Nothing here follows the
kernel's candidates. Results are float64 copies; the inputs are left alone."""

from __future__ import annotations

import numpy as np

from clothtool.solver.penetration import barycentric_grid, round_cone_distance
from tests.reference.collide import friction_correction

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
            push = -d * normal
            q = w @ prev[face, :3]
            fx = friction_correction(*(p + push), *q, *push, *shift, -friction * d)
            correction = push + np.asarray(fx)
            movable = (prev[face, 3] > 0) & (cur[face, 3] > 0)
            m = np.where(movable, w, 0.0)
            norm = m @ m
            if norm <= 0:
                continue
            scale = 1.0 / (1.0 + mass_scale * (push @ push) * meters_per_unit ** 2) if mass_scale > 0 else 1.0
            for particle, weight in zip(face, m):
                if weight == 0:
                    continue
                cur[particle, :3] += correction * min(weight / norm, _MOST)
                cur[particle, 3] *= 1.0 + (scale - 1.0) * weight
    return cur
