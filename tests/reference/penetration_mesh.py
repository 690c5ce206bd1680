"""References for clothtool/solver/kernels/penetration_mesh.py: brute force over every mesh
triangle (no grid), distances by trimesh's closest points and dense sampling of the edges."""

from __future__ import annotations

import numpy as np
import trimesh


def point_triangle_distance(p, a, b, c):
    closest = trimesh.triangles.closest_point(np.array([[a, b, c]], np.float64), np.array([p], np.float64))
    return float(np.linalg.norm(closest[0] - p))


def segment_distance(p0, p1, q0, q1):
    """Minimum over a grid of both parameters, refined three times around the best pair."""
    lo_s = lo_t = 0.0
    span = 1.0
    best = np.inf
    for _ in range(4):
        s = np.clip(lo_s + np.linspace(0, span, 41), 0, 1)
        t = np.clip(lo_t + np.linspace(0, span, 41), 0, 1)
        d = np.linalg.norm((p0 + s[:, None] * (p1 - p0))[:, None] - (q0 + t[:, None] * (q1 - q0))[None], axis=-1)
        i, j = np.unravel_index(d.argmin(), d.shape)
        best = min(best, float(d[i, j]))
        step = span / 40
        span = 4 * step
        lo_s, lo_t = s[i] - 2 * step, t[j] - 2 * step
    return best


def segment_crosses_triangle(p, q, a, b, c):
    n = np.cross(b - a, c - a)
    hp, hq = n @ (p - a), n @ (q - a)
    if hp * hq > 0 or hp == hq:
        return False
    x = p + hp / (hp - hq) * (q - p)
    m = np.stack([b - a, c - a], axis=1)
    (u, v), *_ = np.linalg.lstsq(m, x - a, rcond=None)
    return bool(u >= 0 and v >= 0 and u + v <= 1)


def triangle_distance(A, B):
    if any(segment_crosses_triangle(A[i], A[(i + 1) % 3], *B) or segment_crosses_triangle(B[i], B[(i + 1) % 3], *A) for i in range(3)):
        return 0.0
    candidates = [point_triangle_distance(A[i], *B) for i in range(3)] + [point_triangle_distance(B[i], *A) for i in range(3)]
    candidates += [segment_distance(A[i], A[(i + 1) % 3], B[j], B[(j + 1) % 3]) for i in range(3) for j in range(3)]
    return min(candidates)


def winding_number(p, points, triangles, first, last):
    tris = points[triangles[first:last]] - p
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    la, lb, lc = (np.linalg.norm(v, axis=1) for v in (a, b, c))
    det = np.einsum("ij,ij->i", a, np.cross(b, c))
    div = la * lb * lc + np.einsum("ij,ij->i", a, b) * lc + np.einsum("ij,ij->i", b, c) * la + np.einsum("ij,ij->i", c, a) * lb
    return float((2 * np.arctan2(det, div)).sum() / (4 * np.pi))


def inside_depths(points, mesh_points, mesh_triangles, mesh_first, mesh_closed, mesh_margin, out):
    out[:] = -np.inf
    for k in range(len(mesh_first) - 1):
        first, last = mesh_first[k], mesh_first[k + 1]
        if not mesh_closed[k] or last == first:
            continue
        for i, p in enumerate(points):
            if abs(winding_number(p, mesh_points, mesh_triangles, first, last)) > 0.5:
                nearest = min(point_triangle_distance(p, *mesh_points[t]) for t in mesh_triangles[first:last])
                out[i] = max(out[i], mesh_margin[k] + nearest)


def face_depths(points, triangles, corner_depth, mesh_points, mesh_triangles, margins, cell_start, cell_items, cell_ranges, grid, out):
    """Every mesh triangle within its margin of the face, found without the grid (whose
    arguments are unused)."""
    for f, tri in enumerate(triangles):
        A = points[tri]
        depth = max(corner_depth[tri])
        for t, mt in enumerate(mesh_triangles):
            B = mesh_points[mt]
            if (B.min(0) - margins[t] > A.max(0)).any() or (B.max(0) + margins[t] < A.min(0)).any():
                continue  # farther than the margin
            gap = triangle_distance(A, mesh_points[mt])
            if gap < margins[t]:
                depth = max(depth, margins[t] - gap)
        out[f] = depth
