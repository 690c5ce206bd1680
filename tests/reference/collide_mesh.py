"""References for clothtool/solver/kernels/collide_mesh.py.

The closest point on a triangle is found by projecting onto its plane and, when the
projection falls outside, taking the nearest of the three edges' closest points; the mesh
contact is a brute-force loop over every triangle (no grid), following the side rules of
the kernel module's docstring. The grid references rebuild the same layout with numpy.
"""

from __future__ import annotations

import numpy as np

BARYCENTRIC_SLACK = 1e-5


def _v(*xyz) -> np.ndarray:
    return np.asarray(xyz, np.float64)


def _barycentric(x, a, b, c):
    """(u, v) with x = a + u (b - a) + v (c - a) for x in the plane (least squares)."""
    m = np.stack([b - a, c - a], axis=1)
    (u, v), *_ = np.linalg.lstsq(m, x - a, rcond=None)
    return u, v


def _closest_on_segment(p, a, b):
    ab = b - a
    t = np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0)
    return a + t * ab


def closest_on_triangle(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    p, a, b, c = _v(px, py, pz), _v(ax, ay, az), _v(bx, by, bz), _v(cx, cy, cz)
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n)
    x = p - ((p - a) @ n) * n
    u, v = _barycentric(x, a, b, c)
    if u >= 0 and v >= 0 and u + v <= 1:
        return u, v
    candidates = [_closest_on_segment(p, a, b), _closest_on_segment(p, b, c), _closest_on_segment(p, c, a)]
    best = min(candidates, key=lambda q: np.linalg.norm(p - q))
    return _barycentric(best, a, b, c)


def plane_coordinates(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    a, b, c = _v(ax, ay, az), _v(bx, by, bz), _v(cx, cy, cz)
    if np.linalg.norm(np.cross(b - a, c - a)) <= 1e-15 * np.linalg.norm(b - a) * np.linalg.norm(c - a):
        return 0.0, 0.0, False
    u, v = _barycentric(_v(px, py, pz), a, b, c)
    return u, v, True


def _record(triangle_data, t):
    row = np.asarray(triangle_data[t], np.float64)
    start, end = row[0:9].reshape(3, 3), row[9:18].reshape(3, 3)
    return start, end, row[18:21], row[21:24], row[24], row[25]


def triangle_contact(px, py, pz, qx, qy, qz, triangle_data, t):
    miss = (False, 0.0, 0.0, 0.0, 0.0, 0.0)
    start, end, n0, n1, margin, _ = _record(triangle_data, t)
    if not n1.any():
        return miss
    p, q = _v(px, py, pz), _v(qx, qy, qz)
    h0 = n0 @ (q - start[0])
    side = 1.0 if h0 >= -1e-3 * margin else -1.0
    height = side * (n1 @ (p - end[0]))
    u, v = closest_on_triangle(*p, *end.reshape(-1))
    closest = end[0] + u * (end[1] - end[0]) + v * (end[2] - end[0])
    if height >= 0:  # still on its side: a proximity contact within the margin
        offset = p - closest
        distance = np.linalg.norm(offset)
        if distance >= margin:
            return miss
        push = (margin - distance) * offset / distance if distance > 1e-7 * margin else side * margin * n1
        return (True, *push, u, v)
    # crossed: q carried with the triangle must reach p through the triangle
    u0, v0, ok = plane_coordinates(*q, *start.reshape(-1))
    if not ok:
        return miss
    carried = end[0] + u0 * (end[1] - end[0]) + v0 * (end[2] - end[0]) + h0 * n1
    h1 = n1 @ (p - end[0])
    crossing = carried + h0 / (h0 - h1) * (p - carried)
    uc, vc = _barycentric(crossing, *end)
    if uc < -BARYCENTRIC_SLACK or vc < -BARYCENTRIC_SLACK or uc + vc > 1 + BARYCENTRIC_SLACK:
        return miss
    return (True, *(side * (margin - height) * n1), u, v)


def triangle_bounds(points0, points1, triangles, margins, pad):
    corners = np.concatenate([points0[triangles], points1[triangles]], axis=1).astype(np.float64)
    grow = (np.asarray(margins, np.float64) + pad)[:, None]
    return np.concatenate([corners.min(axis=1) - grow, corners.max(axis=1) + grow], axis=1)


def grid_layout(bounds, max_cells):
    """(cells, grid (7,)): cells of half the mean largest box side, grown by 25% until at most
    max_cells; the origin at the boxes' lower corner."""
    if bounds.shape[0] == 0:
        return 1, np.array([0, 0, 0, 1, 1, 1, 1], np.float64)
    b = np.asarray(bounds, np.float64)
    lo, hi = b[:, :3].min(axis=0), b[:, 3:].max(axis=0)
    size = max(0.5 * (b[:, 3:] - b[:, :3]).max(axis=1).mean(), 1e-12)
    extent = np.maximum(hi - lo, 1e-12)
    while np.prod(np.ceil(extent / size)) > max_cells:
        size *= 1.25
    counts = np.maximum(np.ceil(extent / size), 1)
    return int(np.prod(counts)), np.concatenate([lo, [1.0 / size], counts])


def grid_cell(x, grid, d):
    return int(np.clip(np.floor((x - grid[d]) * grid[3]), 0, int(grid[4 + d]) - 1))


def box_cells(lo, hi, grid):
    """(outside, x0, y0, z0, x1, y1, z1): the cells the box lo..hi covers, clamped; outside
    when it misses the grid."""
    first = np.floor((np.asarray(lo, np.float64) - grid[:3]) * grid[3]).astype(np.int64)
    last = np.floor((np.asarray(hi, np.float64) - grid[:3]) * grid[3]).astype(np.int64)
    counts = np.asarray(grid[4:7], np.int64)
    outside = bool((last < 0).any() or (first >= counts).any())
    return (outside, *np.maximum(first, 0).tolist(), *np.minimum(last, counts - 1).tolist())


def box_cell_count(x0, y0, z0, x1, y1, z1):
    return len(range(x0, x1 + 1)) * len(range(y0, y1 + 1)) * len(range(z0, z1 + 1))


def box_cell(k, x0, y0, z0, x1, y1, z1, grid):
    """The k-th of the box's cells listed z, then y, then x (x fastest), with its index."""
    nx, ny = int(grid[4]), int(grid[5])
    cells = [(x, y, z) for z in range(z0, z1 + 1) for y in range(y0, y1 + 1) for x in range(x0, x1 + 1)]
    x, y, z = cells[k]
    return x, y, z, (z * ny + y) * nx + x


def first_shared_cell(t, x, y, z, x0, y0, z0, cell_ranges):
    """The lowest corner of the overlap of the box (from x0, y0, z0) and triangle t's cells."""
    first = np.maximum([x0, y0, z0], np.asarray(cell_ranges[t, :3], np.int64))
    return bool((first == [x, y, z]).all())


def grid_cell_ranges(bounds, grid):
    """(entries, cell_ranges (t,6))."""
    ranges = np.array(
        [[grid_cell(row[d + 3 * side], grid, d) for side in (0, 1) for d in range(3)] for row in bounds], np.int64
    ).reshape(-1, 6)
    return int(np.prod(ranges[:, 3:] - ranges[:, :3] + 1, axis=1).sum()), ranges


def grid_fill(cell_ranges, grid):
    """(cell_start (cells+1,), cell_items): every cell's triangles in increasing order."""
    nx, ny, nz = (int(v) for v in grid[4:7])
    members: list[list[int]] = [[] for _ in range(nx * ny * nz)]
    for t, (x0, y0, z0, x1, y1, z1) in enumerate(cell_ranges):
        for z in range(z0, z1 + 1):
            for y in range(y0, y1 + 1):
                for x in range(x0, x1 + 1):
                    members[(z * ny + y) * nx + x].append(t)
    start = np.concatenate([[0], np.cumsum([len(m) for m in members])]).astype(np.int64)
    items = np.array([t for m in members for t in m], np.int64)
    return start, items


def to_world(frame, end, x, y, z):
    f = np.asarray(frame, np.float64)
    rotation, translation = f[4 * end: 4 * end + 3], f[4 * end + 3]
    return tuple(rotation @ _v(x, y, z) + translation)


def mesh_contact(px, py, pz, qx, qy, qz, triangle_data, cell_start, cell_items, cell_ranges, grid, frame):
    """Brute force over every triangle: the contact with the largest push-out."""
    best, result = -1.0, (False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    for t in range(triangle_data.shape[0]):
        hit, dx, dy, dz, u, v = triangle_contact(px, py, pz, qx, qy, qz, triangle_data, t)
        size = dx * dx + dy * dy + dz * dz
        if hit and size > best:
            start, end, _, _, _, mu = _record(triangle_data, t)
            weights = np.array([1 - u - v, u, v])
            shift = weights @ (end - start)
            best, result = size, (True, dx, dy, dz, *shift, mu)
    return result


def triangle_contact_within(px, py, pz, qx, qy, qz, triangle_data, t, margin):
    data = np.array(triangle_data, np.float64)
    data[t, 24] = margin
    return triangle_contact(px, py, pz, qx, qy, qz, data, t)
