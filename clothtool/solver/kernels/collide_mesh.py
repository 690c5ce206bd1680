"""Triangle-mesh colliders: point-triangle contacts and the uniform grid that finds them.

Side handling (meshes may be thin, open sheets): the side a particle belongs to is the side of
the triangle's plane its *previous* position was on, relative to the triangle at the start of
the iteration (s = +1 on the outward side, on the plane or behind it by less than 1e-3 of the
margin, which is rounding of a particle sliding along the face; -1 farther behind it). At the end of the
iteration, with h = s n . (p - a) the particle's height on that side:

* h >= 0 (still on its side): a contact when the distance to the triangle's closest point q is
  below the margin; the push-out moves p to the margin along (p - q) / |p - q| (the normal
  when q is inside the triangle, away from an edge or corner otherwise).
* h < 0 (it crossed the plane): a contact only when the crossing itself went through the
  triangle: the previous position is carried with the triangle (same barycentric coordinates
  and height at the end pose) and the segment from there to p meets the end triangle inside
  it. The push-out takes p back to height ``margin`` on its side along the normal, however
  deep it went. A particle that passed beside the triangle is left to the triangle it crossed.

So a sheet is solid from both sides and nothing tunnels through a mesh, even a fast one; the
cost is that a particle that starts inside a closed mesh stays inside. Of all the triangles a
particle touches, only the one with the largest push-out counts (NvCloth also keeps one
triangle per particle), so the faces meeting at an edge do not cancel each other.

Packed triangle records, float32 (t, 32), filled each iteration by the stage:
a0 b0 c0 (start corners, 9) a1 b1 c1 (end corners, 9) n0 n1 (unit normals, 6; zero for a
degenerate triangle) margin friction, and the end pose's box grown by the margin (lo xyz,
hi xyz), which rejects most candidates before the closest-point search.

The grid lives in world space, built once per frame over each triangle's box at the frame's
start and end poses grown by its margin; a particle queries the cells of the box of its world
positions at the iteration's start and end, and meets each triangle once: in the first cell
that both boxes share.
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel
from clothtool._minmax import largest, smallest

BARYCENTRIC_SLACK = np.float32(1e-5)
SIDE_SLACK = np.float32(1e-3)  # of the margin: how far behind the plane still counts as its front


@kernel(device=True)  # only kernels call it: their twin, without a CPython wrapper to compile
def closest_on_triangle(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """(u, v): barycentric weights of b and c of the point of triangle abc closest to p
    (the point is a + u (b - a) + v (c - a)); Voronoi regions of the corners, edges, face."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    e1x, e1y, e1z = bx - ax, by - ay, bz - az
    e2x, e2y, e2z = cx - ax, cy - ay, cz - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = e1x * apx + e1y * apy + e1z * apz
    d2 = e2x * apx + e2y * apy + e2z * apz
    if d1 <= zero and d2 <= zero:
        return zero, zero  # corner a
    bpx, bpy, bpz = px - bx, py - by, pz - bz
    d3 = e1x * bpx + e1y * bpy + e1z * bpz
    d4 = e2x * bpx + e2y * bpy + e2z * bpz
    if d3 >= zero and d4 <= d3:
        return one, zero  # corner b
    vc = d1 * d4 - d3 * d2
    if vc <= zero and d1 >= zero and d3 <= zero:
        return d1 / (d1 - d3), zero  # edge ab
    cpx, cpy, cpz = px - cx, py - cy, pz - cz
    d5 = e1x * cpx + e1y * cpy + e1z * cpz
    d6 = e2x * cpx + e2y * cpy + e2z * cpz
    if d6 >= zero and d5 <= d6:
        return zero, one  # corner c
    vb = d5 * d2 - d1 * d6
    if vb <= zero and d2 >= zero and d6 <= zero:
        return zero, d2 / (d2 - d6)  # edge ac
    va = d3 * d6 - d5 * d4
    if va <= zero and (d4 - d3) >= zero and (d5 - d6) >= zero:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return one - w, w  # edge bc
    denominator = one / (va + vb + vc)
    return vb * denominator, vc * denominator  # face


@kernel
def plane_coordinates(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """(u, v, ok): barycentric weights of b and c of p's projection onto abc's plane
    (unclamped); ok is False for a degenerate triangle."""
    e1x, e1y, e1z = bx - ax, by - ay, bz - az
    e2x, e2y, e2z = cx - ax, cy - ay, cz - az
    dx, dy, dz = px - ax, py - ay, pz - az
    d11 = e1x * e1x + e1y * e1y + e1z * e1z
    d12 = e1x * e2x + e1y * e2y + e1z * e2z
    d22 = e2x * e2x + e2y * e2y + e2z * e2z
    r1 = dx * e1x + dy * e1y + dz * e1z
    r2 = dx * e2x + dy * e2y + dz * e2z
    det = d11 * d22 - d12 * d12
    if not det > np.float32(1e-30) * (d11 * d22):
        return np.float32(0.0), np.float32(0.0), False
    inv = np.float32(1.0) / det
    return (d22 * r1 - d12 * r2) * inv, (d11 * r2 - d12 * r1) * inv, True


@kernel(inline="always")
def triangle_contact(px, py, pz, qx, qy, qz, triangle_data, t):
    """Contact of the particle moving q -> p with triangle t (see the module docstring).

    Returns (hit, dx, dy, dz, u, v): the push-out and the barycentric weights (of corners b
    and c) of the surface point it refers to, which friction uses for the surface's motion.
    """
    return triangle_contact_within(px, py, pz, qx, qy, qz, triangle_data, t, triangle_data[t, 24])


@kernel(inline="always")
def triangle_contact_within(px, py, pz, qx, qy, qz, triangle_data, t, margin):
    """triangle_contact with the given ``margin`` instead of the record's own, which must be
    at least as large (its box, grown by the record's margin, rejects far points)."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    miss = (False, zero, zero, zero, zero, zero)
    T = triangle_data
    n1x, n1y, n1z = T[t, 21], T[t, 22], T[t, 23]
    if n1x == zero and n1y == zero and n1z == zero:
        return miss  # degenerate
    h0 = T[t, 18] * (qx - T[t, 0]) + T[t, 19] * (qy - T[t, 1]) + T[t, 20] * (qz - T[t, 2])
    # a particle grazing the plane (float noise of a box's face under a particle sliding
    # along it) belongs to the outward side: it cannot have come from inside a closed mesh
    side = one if h0 >= -SIDE_SLACK * margin else -one
    a1x, a1y, a1z = T[t, 9], T[t, 10], T[t, 11]
    b1x, b1y, b1z = T[t, 12], T[t, 13], T[t, 14]
    c1x, c1y, c1z = T[t, 15], T[t, 16], T[t, 17]
    h1 = n1x * (px - a1x) + n1y * (py - a1y) + n1z * (pz - a1z)
    height = side * h1
    if height >= margin:
        return miss  # the plane alone is farther than the margin
    if height >= zero:
        if (
            px < T[t, 26] or py < T[t, 27] or pz < T[t, 28]
            or px > T[t, 29] or py > T[t, 30] or pz > T[t, 31]
        ):
            return miss  # farther than the margin from the triangle's box
        u, v = closest_on_triangle(px, py, pz, a1x, a1y, a1z, b1x, b1y, b1z, c1x, c1y, c1z)
        w = one - u - v
        ox = px - (w * a1x + u * b1x + v * c1x)
        oy = py - (w * a1y + u * b1y + v * c1y)
        oz = pz - (w * a1z + u * b1z + v * c1z)
        distance = np.sqrt(ox * ox + oy * oy + oz * oz)
        if distance >= margin:
            return miss
        if distance > np.float32(1e-7) * margin:
            scale = (margin - distance) / distance
            return True, ox * scale, oy * scale, oz * scale, u, v
        scale = side * margin
        return True, n1x * scale, n1y * scale, n1z * scale, u, v
    # crossed the plane: carry q with the triangle, then intersect the segment with it
    u0, v0, ok = plane_coordinates(qx, qy, qz, T[t, 0], T[t, 1], T[t, 2], T[t, 3], T[t, 4], T[t, 5], T[t, 6], T[t, 7], T[t, 8])
    if not ok:
        return miss
    w0 = one - u0 - v0
    cx = w0 * a1x + u0 * b1x + v0 * c1x + h0 * n1x
    cy = w0 * a1y + u0 * b1y + v0 * c1y + h0 * n1y
    cz = w0 * a1z + u0 * b1z + v0 * c1z + h0 * n1z
    f = h0 / (h0 - h1)
    uc, vc, ok = plane_coordinates(
        cx + f * (px - cx), cy + f * (py - cy), cz + f * (pz - cz), a1x, a1y, a1z, b1x, b1y, b1z, c1x, c1y, c1z
    )
    if not ok or uc < -BARYCENTRIC_SLACK or vc < -BARYCENTRIC_SLACK or uc + vc > one + BARYCENTRIC_SLACK:
        return miss
    u, v = closest_on_triangle(px, py, pz, a1x, a1y, a1z, b1x, b1y, b1z, c1x, c1y, c1z)
    scale = side * (margin - height)
    return True, n1x * scale, n1y * scale, n1z * scale, u, v


# ---------------------------------------------------------------------------------- grid
@kernel
def triangle_bounds(points0, points1, triangles, margins, pad, bounds):
    """bounds (t,6) lo xyz, hi xyz: each triangle's box over both poses, grown by its margin
    plus ``pad``."""
    for t in range(triangles.shape[0]):
        grow = margins[t] + pad
        for d in range(3):
            lo = np.inf
            hi = -np.inf
            for c in range(3):
                p = triangles[t, c]
                lo = smallest(lo, points0[p, d], points1[p, d])
                hi = largest(hi, points0[p, d], points1[p, d])
            bounds[t, d] = lo - grow
            bounds[t, 3 + d] = hi + grow


@kernel
def grid_layout(bounds, max_cells, grid):
    """Choose the grid, written to grid (7,): origin xyz, 1 / cell size, cells along x y z.

    Cells start at half the average of the triangle boxes' largest sides and grow by 25%
    until there are at most ``max_cells``. Returns the cell count."""
    t = bounds.shape[0]
    if t == 0:
        grid[:] = 0.0
        grid[3:] = 1.0
        return 1
    lo0 = lo1 = lo2 = np.inf
    hi0 = hi1 = hi2 = -np.inf
    mean = 0.0
    for i in range(t):
        lo0 = smallest(lo0, bounds[i, 0])
        lo1 = smallest(lo1, bounds[i, 1])
        lo2 = smallest(lo2, bounds[i, 2])
        hi0 = largest(hi0, bounds[i, 3])
        hi1 = largest(hi1, bounds[i, 4])
        hi2 = largest(hi2, bounds[i, 5])
        mean += largest(bounds[i, 3] - bounds[i, 0], bounds[i, 4] - bounds[i, 1], bounds[i, 5] - bounds[i, 2])
    size = largest(0.5 * mean / t, 1e-12)
    e0 = largest(hi0 - lo0, 1e-12)
    e1 = largest(hi1 - lo1, 1e-12)
    e2 = largest(hi2 - lo2, 1e-12)
    while np.ceil(e0 / size) * np.ceil(e1 / size) * np.ceil(e2 / size) > max_cells:
        size *= 1.25
    n0 = largest(int(np.ceil(e0 / size)), 1)
    n1 = largest(int(np.ceil(e1 / size)), 1)
    n2 = largest(int(np.ceil(e2 / size)), 1)
    grid[0] = lo0
    grid[1] = lo1
    grid[2] = lo2
    grid[3] = 1.0 / size
    grid[4] = n0
    grid[5] = n1
    grid[6] = n2
    return n0 * n1 * n2


@kernel
def grid_cell(x, grid, d):
    """Index of the cell holding coordinate x along axis d, clamped to the grid."""
    c = int(np.floor((x - grid[d]) * grid[3]))
    return smallest(largest(c, 0), int(grid[4 + d]) - 1)


@kernel
def box_cells(lox, loy, loz, hix, hiy, hiz, grid):
    """The cells a world box covers: (outside, x0, y0, z0, x1, y1, z1), clamped to the grid;
    ``outside`` when the box misses the grid entirely."""
    inv = grid[3]
    x0 = int(np.floor((lox - grid[0]) * inv))
    y0 = int(np.floor((loy - grid[1]) * inv))
    z0 = int(np.floor((loz - grid[2]) * inv))
    x1 = int(np.floor((hix - grid[0]) * inv))
    y1 = int(np.floor((hiy - grid[1]) * inv))
    z1 = int(np.floor((hiz - grid[2]) * inv))
    nx = int(grid[4])
    ny = int(grid[5])
    nz = int(grid[6])
    outside = x1 < 0 or y1 < 0 or z1 < 0 or x0 >= nx or y0 >= ny or z0 >= nz
    return outside, largest(x0, 0), largest(y0, 0), largest(z0, 0), smallest(x1, nx - 1), smallest(y1, ny - 1), smallest(z1, nz - 1)


# A box query (the kernels that look up triangles near a point's move or a cloth triangle) walks
# the box_cells of its box with the three helpers below: cells in grid_fill's order, each
# triangle tested in one cell only.
@kernel(inline="always")
def box_cell_count(x0, y0, z0, x1, y1, z1):
    """How many cells the box of cells x0..x1, y0..y1, z0..z1 (box_cells, not outside) holds."""
    return (x1 - x0 + 1) * (y1 - y0 + 1) * (z1 - z0 + 1)


@kernel(inline="always")
def box_cell(k, x0, y0, z0, x1, y1, z1, grid):
    """Cell k (0 <= k < box_cell_count) of the box of cells, x fastest, then y, then z:
    (x, y, z, the cell's index c = (z * ny + y) * nx + x into cell_start)."""
    wx = x1 - x0 + 1
    wy = y1 - y0 + 1
    x = x0 + k % wx
    y = y0 + (k // wx) % wy
    z = z0 + k // (wx * wy)
    return x, y, z, (z * int(grid[5]) + y) * int(grid[4]) + x


@kernel(inline="always")
def first_shared_cell(t, x, y, z, x0, y0, z0, cell_ranges):
    """Whether cell (x, y, z) of a box whose first cell is (x0, y0, z0) is the first cell (the
    lowest on each axis) that the box shares with triangle t's cells: a query that tests t
    there only tests each triangle once, however many of the box's cells hold it."""
    return x == largest(x0, cell_ranges[t, 0]) and y == largest(y0, cell_ranges[t, 1]) and z == largest(z0, cell_ranges[t, 2])


@kernel
def grid_cell_ranges(bounds, grid, cell_ranges):
    """cell_ranges (t,6): each triangle's first and last cell per axis; returns the number
    of (triangle, cell) entries."""
    total = 0
    for t in range(bounds.shape[0]):
        n = 1
        for d in range(3):
            lo = grid_cell(bounds[t, d], grid, d)
            hi = grid_cell(bounds[t, 3 + d], grid, d)
            cell_ranges[t, d] = lo
            cell_ranges[t, 3 + d] = hi
            n *= hi - lo + 1
        total += n
    return total


@kernel
def grid_fill(cell_ranges, grid, cell_start, cell_items):
    """Counting sort of triangles into cells: cell c = (z * ny + y) * nx + x holds
    cell_items[cell_start[c]:cell_start[c+1]], in increasing triangle order (cell_start has at
    least cells + 1 entries, cell_items at least as many as the entries)."""
    nx = int(grid[4])
    ny = int(grid[5])
    cells = nx * ny * int(grid[6])
    for c in range(cells + 1):
        cell_start[c] = 0
    for t in range(cell_ranges.shape[0]):
        for z in range(cell_ranges[t, 2], cell_ranges[t, 5] + 1):
            for y in range(cell_ranges[t, 1], cell_ranges[t, 4] + 1):
                for x in range(cell_ranges[t, 0], cell_ranges[t, 3] + 1):
                    cell_start[(z * ny + y) * nx + x + 1] += 1
    for c in range(cells):
        cell_start[c + 1] += cell_start[c]
    for t in range(cell_ranges.shape[0]):
        for z in range(cell_ranges[t, 2], cell_ranges[t, 5] + 1):
            for y in range(cell_ranges[t, 1], cell_ranges[t, 4] + 1):
                for x in range(cell_ranges[t, 0], cell_ranges[t, 3] + 1):
                    cell = (z * ny + y) * nx + x
                    cell_items[cell_start[cell]] = t
                    cell_start[cell] += 1
    for c in range(cells, 0, -1):
        cell_start[c] = cell_start[c - 1]
    cell_start[0] = 0


@kernel
def to_world(frame, end, x, y, z):
    """R x + T with the frame's pose at the iteration's start (end = 0) or end (end = 1);
    frame (8,3) float64 holds R0 (rows 0-2), T0 (row 3), R1 (rows 4-6), T1 (row 7)."""
    o = 4 * end
    wx = frame[o, 0] * x + frame[o, 1] * y + frame[o, 2] * z + frame[o + 3, 0]
    wy = frame[o + 1, 0] * x + frame[o + 1, 1] * y + frame[o + 1, 2] * z + frame[o + 3, 1]
    wz = frame[o + 2, 0] * x + frame[o + 2, 1] * y + frame[o + 2, 2] * z + frame[o + 3, 2]
    return wx, wy, wz


@kernel(inline="always")
def mesh_contact(px, py, pz, qx, qy, qz, triangle_data, cell_start, cell_items, cell_ranges, grid, frame):
    """The mesh contact of the particle moving q -> p (local frame) with the largest push-out:
    (hit, dx, dy, dz, sx, sy, sz, friction), s the surface's displacement over the iteration at
    the contact. The grid is in world space: the frame's poses take q and p there."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    best = -one
    hit = False
    rx = ry = rz = zero
    sx = sy = sz = zero
    mu = zero
    wpx, wpy, wpz = to_world(frame, 1, px, py, pz)
    wqx, wqy, wqz = to_world(frame, 0, qx, qy, qz)
    outside, x0, y0, z0, x1, y1, z1 = box_cells(
        smallest(wpx, wqx), smallest(wpy, wqy), smallest(wpz, wqz), largest(wpx, wqx), largest(wpy, wqy), largest(wpz, wqz), grid
    )
    if outside:
        return hit, rx, ry, rz, sx, sy, sz, mu
    T = triangle_data
    single = x0 == x1 and y0 == y1 and z0 == z1  # one cell: no triangle can come twice
    for k in range(box_cell_count(x0, y0, z0, x1, y1, z1)):
        x, y, z, cell = box_cell(k, x0, y0, z0, x1, y1, z1, grid)
        for e in range(cell_start[cell], cell_start[cell + 1]):
            t = cell_items[e]
            if not (single or first_shared_cell(t, x, y, z, x0, y0, z0, cell_ranges)):
                continue
            ok, dx, dy, dz, u, v = triangle_contact(px, py, pz, qx, qy, qz, triangle_data, t)
            if not ok:
                continue
            size = dx * dx + dy * dy + dz * dz
            if size > best:
                best = size
                hit = True
                rx, ry, rz = dx, dy, dz
                w = one - u - v
                sx = w * (T[t, 9] - T[t, 0]) + u * (T[t, 12] - T[t, 3]) + v * (T[t, 15] - T[t, 6])
                sy = w * (T[t, 10] - T[t, 1]) + u * (T[t, 13] - T[t, 4]) + v * (T[t, 16] - T[t, 7])
                sz = w * (T[t, 11] - T[t, 2]) + u * (T[t, 14] - T[t, 5]) + v * (T[t, 17] - T[t, 8])
                mu = T[t, 25]
    return hit, rx, ry, rz, sx, sy, sz, mu
