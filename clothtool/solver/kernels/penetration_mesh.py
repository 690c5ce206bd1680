"""How deep a cloth's faces reach into its triangle-mesh colliders (a measurement, float64).

A mesh collider's surface lies its margin (thickness) off the mesh. A cloth triangle that
does not meet the mesh reaches ``margin - distance`` into it, with the exact distance
between the two triangles: the smallest of the corner-to-triangle (both ways) and
edge-to-edge distances. A cloth triangle that meets the mesh (an edge of one crosses the
other) reaches at least the margin; one with a corner inside a closed mesh (generalized
winding number above 1/2 in magnitude: either orientation) at least the margin plus that
corner's distance to the mesh. Those two are lower bounds of a face already through the
mesh's surface, exact depths otherwise. Open meshes (an edge without two triangles) have no
inside: a face is measured against them as against a two-sided sheet.

Candidates come from the collide kernels' grid (clothtool.solver.kernels.collide_mesh) over
the mesh triangles' boxes grown by their margins: only pairs closer than the margin count.
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel
from clothtool._minmax import largest, smallest
from clothtool.solver.kernels.collide_mesh import (
    box_cell,
    box_cell_count,
    box_cells,
    closest_on_triangle,
    first_shared_cell,
    plane_coordinates,
)


@kernel
def point_triangle_distance(p, a, b, c):
    """Distance from point p to triangle abc (3-vectors)."""
    u, v = closest_on_triangle(p[0], p[1], p[2], a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2])
    w = 1.0 - u - v
    return np.sqrt(np.sum((p - (w * a + u * b + v * c)) ** 2))


@kernel
def segment_distance(p0, p1, q0, q1):
    """Distance between the segments p0p1 and q0q1 (Ericson, Real-Time Collision Detection 5.1.9)."""
    d1 = p1 - p0
    d2 = q1 - q0
    r = p0 - q0
    a = np.sum(d1 * d1)
    e = np.sum(d2 * d2)
    f = np.sum(d2 * r)
    tiny = 1e-30
    if a <= tiny and e <= tiny:
        return np.sqrt(np.sum(r * r))
    if a <= tiny:
        s = 0.0
        t = smallest(largest(f / e, 0.0), 1.0)
    else:
        c = np.sum(d1 * r)
        if e <= tiny:
            t = 0.0
            s = smallest(largest(-c / a, 0.0), 1.0)
        else:
            b = np.sum(d1 * d2)
            denominator = a * e - b * b
            s = smallest(largest((b * f - c * e) / denominator, 0.0), 1.0) if denominator > tiny * a * e else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = smallest(largest(-c / a, 0.0), 1.0)
            elif t > 1.0:
                t = 1.0
                s = smallest(largest((b - c) / a, 0.0), 1.0)
    gap = p0 + s * d1 - (q0 + t * d2)
    return np.sqrt(np.sum(gap * gap))


@kernel
def segment_crosses_triangle(p, q, a, b, c):
    """True when the segment pq meets triangle abc (touching included)."""
    n = np.cross(b - a, c - a)
    hp = np.sum(n * (p - a))
    hq = np.sum(n * (q - a))
    if (hp > 0.0 and hq > 0.0) or (hp < 0.0 and hq < 0.0) or hp == hq:
        return False  # one side, or parallel to the plane (then the edge distances see it)
    x = p + (hp / (hp - hq)) * (q - p)
    u, v, ok = plane_coordinates(x[0], x[1], x[2], a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2])
    return ok and u >= 0.0 and v >= 0.0 and u + v <= 1.0


@kernel
def triangle_distance(A, B):
    """Distance between triangles A and B ((3,3) corners each); 0 when they meet."""
    for i in range(3):
        j = (i + 1) % 3
        if segment_crosses_triangle(A[i], A[j], B[0], B[1], B[2]) or segment_crosses_triangle(B[i], B[j], A[0], A[1], A[2]):
            return 0.0
    best = np.inf
    for i in range(3):
        best = smallest(best, point_triangle_distance(A[i], B[0], B[1], B[2]), point_triangle_distance(B[i], A[0], A[1], A[2]))
        for j in range(3):
            best = smallest(best, segment_distance(A[i], A[(i + 1) % 3], B[j], B[(j + 1) % 3]))
    return best


@kernel
def winding_number(p, points, triangles, first, last):
    """Generalized winding number of p w.r.t. triangles[first:last] (Van Oosterom & Strackee).
    Scalar arithmetic: it runs for every particle against every body triangle, and small
    temporary arrays per triangle made it the bulk of a bake's stats time."""
    px, py, pz = p[0], p[1], p[2]
    total = 0.0
    for t in range(first, last):
        i, j, k = triangles[t, 0], triangles[t, 1], triangles[t, 2]
        ax, ay, az = points[i, 0] - px, points[i, 1] - py, points[i, 2] - pz
        bx, by, bz = points[j, 0] - px, points[j, 1] - py, points[j, 2] - pz
        cx, cy, cz = points[k, 0] - px, points[k, 1] - py, points[k, 2] - pz
        la = np.sqrt(ax * ax + ay * ay + az * az)
        lb = np.sqrt(bx * bx + by * by + bz * bz)
        lc = np.sqrt(cx * cx + cy * cy + cz * cz)
        det = ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)
        div = la * lb * lc + (ax * bx + ay * by + az * bz) * lc + (bx * cx + by * cy + bz * cz) * la + (cx * ax + cy * ay + cz * az) * lb
        total += 2.0 * np.arctan2(det, div)
    return total / (4.0 * np.pi)


@kernel
def inside_depths(points, mesh_points, mesh_triangles, mesh_first, mesh_closed, mesh_margin, out):
    """out (n,): for each point inside a closed mesh (mesh k's triangles are
    mesh_triangles[mesh_first[k]:mesh_first[k+1]]), that mesh's margin plus the point's
    distance to it, the largest over the meshes; -inf for a point inside none."""
    for i in range(points.shape[0]):
        out[i] = -np.inf
    for k in range(mesh_first.shape[0] - 1):
        first = mesh_first[k]
        last = mesh_first[k + 1]
        if not mesh_closed[k] or last == first:
            continue
        lo = np.full(3, np.inf)
        hi = np.full(3, -np.inf)
        for t in range(first, last):
            for corner in range(3):
                lo = np.minimum(lo, mesh_points[mesh_triangles[t, corner]])
                hi = np.maximum(hi, mesh_points[mesh_triangles[t, corner]])
        for i in range(points.shape[0]):
            p = points[i]
            if np.any(p < lo) or np.any(p > hi):
                continue
            if abs(winding_number(p, mesh_points, mesh_triangles, first, last)) <= 0.5:
                continue
            nearest = np.inf
            for t in range(first, last):
                tri = mesh_triangles[t]
                nearest = smallest(nearest, point_triangle_distance(p, mesh_points[tri[0]], mesh_points[tri[1]], mesh_points[tri[2]]))
            out[i] = largest(out[i], mesh_margin[k] + nearest)


@kernel
def face_depths(points, triangles, corner_depth, mesh_points, mesh_triangles, margins, cell_start, cell_items, cell_ranges, grid, out):
    """out (f,): how deep each cloth triangle reaches into the meshes (see the module
    docstring; negative: minus its clearance), -inf when no mesh triangle's box grown by its
    margin meets the triangle's box and no corner is inside; corner_depth (n,) from
    inside_depths; the grid (collide_mesh) over the mesh triangles' boxes grown by ``margins``."""
    A = np.empty((3, 3))
    B = np.empty((3, 3))
    for f in range(triangles.shape[0]):
        depth = -np.inf
        for corner in range(3):
            A[corner] = points[triangles[f, corner]]
            depth = largest(depth, corner_depth[triangles[f, corner]])
        low = np.empty(3)
        high = np.empty(3)
        for d in range(3):
            low[d] = A[:, d].min()
            high[d] = A[:, d].max()
        outside, x0, y0, z0, x1, y1, z1 = box_cells(low[0], low[1], low[2], high[0], high[1], high[2], grid)
        for k in range(0 if outside else box_cell_count(x0, y0, z0, x1, y1, z1)):
            x, y, z, cell = box_cell(k, x0, y0, z0, x1, y1, z1, grid)
            for e in range(cell_start[cell], cell_start[cell + 1]):
                t = cell_items[e]
                if not first_shared_cell(t, x, y, z, x0, y0, z0, cell_ranges):
                    continue  # visit each mesh triangle once
                for corner in range(3):
                    B[corner] = mesh_points[mesh_triangles[t, corner]]
                apart = False
                for d in range(3):
                    apart = apart or B[:, d].min() - margins[t] > high[d] or B[:, d].max() + margins[t] < low[d]
                if apart:
                    continue  # the boxes are apart: farther than the margin
                depth = largest(depth, margins[t] - triangle_distance(A, B))
        out[f] = depth
