"""Broad phase of the virtual-particle kernel: whether a triangle's points can touch a collider.

collide_virtual's rows may come in runs that share one triangle (the cooker batches a
fabric's virtual particles conflict-free, so its runs are short; runs shorter than MIN_RUN
are tested point by point). Every point of a row is a convex
combination of the triangle's corners, at the iteration's start (q, from ``prev``) and end
(p, from ``cur``), so every p and q, and every point of every path q -> p, lies in the ball
of centre C (the current corners' centroid) and radius B (the farthest of the six corners
from C). When that ball is beyond the reach of every collider, ``point_correction`` returns
no contact and no continuous move for each of the run's points, and collide_virtual leaves
them alone: the run is skipped and the result is the same, bit for bit. Beyond reach means,
in float64, by more than ``SLACK`` of the magnitudes involved (rounding of the kernels'
float32 arithmetic is millions of times smaller):

* sphere, discrete: |C - c1| > B + r1 (r: radius plus margin, end pose c1, r1);
* sphere, continuous: the distance of C from the centre's path c0 -> c1 exceeds
  B + max(r0, r1) (the moving point and the moving sphere never meet);
* capsule (the hull of its end spheres lies within max(ra, rb) of its axis segment),
  discrete: dist(C, a1 b1) > B + max(ra1, rb1); continuous: the axis at time t lies within
  m t of the start axis and m (1 - t) of the end one (m: the larger end's travel), so it is
  at least (d0 + d1 - m) / 2 from C, which must exceed B + the largest radius + the time of
  impact's tolerance (collide_shapes.capsule_time_of_impact reports a touch within it);
* convex: one of its planes has the whole ball on its outer side by more than the margin;
* mesh: every grid cell that the ball's world box (at the iteration's start and end frame
  poses) covers is empty, so mesh_contact, which visits only the cells of the box of a
  point's world positions, finds no triangle.
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel
from clothtool.solver.kernels.collide_mesh import box_cells, to_world

# Relative margin of the tests (of the sum of the magnitudes of the quantities compared).
SLACK = 1e-4
# Runs shorter than this are tested point by point: the ball costs as much as one point.
MIN_RUN = 2


@kernel(inline="always")
def run_end(virtual, r):
    """The first row after ``r`` whose triangle (i, j, k) differs from row r's."""
    a = virtual[r, 0]
    b = virtual[r, 1]
    c = virtual[r, 2]
    end = r + 1
    while end < virtual.shape[0] and virtual[end, 0] == a and virtual[end, 1] == b and virtual[end, 2] == c:
        end += 1
    return end


@kernel(inline="always")
def triangle_ball(cur, prev, a, b, c):
    """(cx, cy, cz, radius) float64: a ball holding particles a, b, c at ``cur`` and ``prev``."""
    cx = (np.float64(cur[a, 0]) + np.float64(cur[b, 0]) + np.float64(cur[c, 0])) / 3.0
    cy = (np.float64(cur[a, 1]) + np.float64(cur[b, 1]) + np.float64(cur[c, 1])) / 3.0
    cz = (np.float64(cur[a, 2]) + np.float64(cur[b, 2]) + np.float64(cur[c, 2])) / 3.0
    square = 0.0  # the largest squared distance: one square root (sqrt is monotonic and exact)
    for state in (cur, prev):
        for particle in (a, b, c):
            dx = np.float64(state[particle, 0]) - cx
            dy = np.float64(state[particle, 1]) - cy
            dz = np.float64(state[particle, 2]) - cz
            square = max(square, dx * dx + dy * dy + dz * dz)
    return cx, cy, cz, np.sqrt(square)


@kernel(device=True)
def impact_tolerance(radius):
    """How near the surface collide_shapes.capsule_time_of_impact reports a touch (it stops
    within 1e-4 of the smaller radius): bounded here by the largest radius ``radius``."""
    return 1e-4 * radius + 1e-9


@kernel(inline="always")
def triangle_box(cur, prev, a, b, c):
    """(lo xyz, hi xyz) float64: the box of particles a, b, c at ``cur`` and ``prev`` (exact:
    min and max do not round)."""
    lx = hx = np.float64(cur[a, 0])
    ly = hy = np.float64(cur[a, 1])
    lz = hz = np.float64(cur[a, 2])
    for state in (cur, prev):
        for particle in (a, b, c):
            x = np.float64(state[particle, 0])
            y = np.float64(state[particle, 1])
            z = np.float64(state[particle, 2])
            lx, hx = min(lx, x), max(hx, x)
            ly, hy = min(ly, y), max(hy, y)
            lz, hz = min(lz, z), max(hz, z)
    return lx, ly, lz, hx, hy, hz


@kernel(device=True)
def _grow_box(out, k, x, y, z, r):
    """Grow box k of ``out`` (lo xyz, hi xyz) to hold the ball (x, y, z, r)."""
    out[k, 0] = min(out[k, 0], x - r)
    out[k, 1] = min(out[k, 1], y - r)
    out[k, 2] = min(out[k, 2], z - r)
    out[k, 3] = max(out[k, 3], x + r)
    out[k, 4] = max(out[k, 4], y + r)
    out[k, 5] = max(out[k, 5], z + r)


@kernel(device=True)
def collider_boxes(sphere_data, capsule_data, swept, out):
    """out (s+c, 6) float64: a box per sphere, then per capsule, holding it at the end pose
    (``swept``: over its motion through the iteration, the box of its start and end poses:
    a sphere interpolated between two lies in their boxes' hull; for capsules grown by
    capsule_time_of_impact's tolerance), then grown by SLACK of its coordinates' magnitude."""
    S, C = sphere_data, capsule_data
    s_count = S.shape[0]
    for k in range(s_count + C.shape[0]):
        out[k, 0] = out[k, 1] = out[k, 2] = np.inf
        out[k, 3] = out[k, 4] = out[k, 5] = -np.inf
        if k < s_count:
            _grow_box(out, k, np.float64(S[k, 4]), np.float64(S[k, 5]), np.float64(S[k, 6]), np.float64(S[k, 7]))
            if swept:
                _grow_box(out, k, np.float64(S[k, 0]), np.float64(S[k, 1]), np.float64(S[k, 2]), np.float64(S[k, 3]))
            tolerance = 0.0
        else:
            c = k - s_count
            largest = 0.0
            for first in (8, 12, 0, 4):
                if first < 8 and not swept:
                    break
                radius = np.float64(C[c, first + 3])
                largest = max(largest, abs(radius))
                _grow_box(out, k, np.float64(C[c, first]), np.float64(C[c, first + 1]), np.float64(C[c, first + 2]), radius)
            tolerance = impact_tolerance(largest) if swept else 0.0
        grow = tolerance + SLACK * (abs(out[k, 0]) + abs(out[k, 1]) + abs(out[k, 2]) + abs(out[k, 3]) + abs(out[k, 4]) + abs(out[k, 5]))
        for d in range(3):
            out[k, d] -= grow
            out[k, 3 + d] += grow


@kernel(inline="always")
def boxes_miss(lx, ly, lz, hx, hy, hz, boxes):
    """True when the box (l, h) is apart from every box of ``boxes`` (collider_boxes) by more
    than SLACK of its own coordinates' magnitude: no point of it (or, within rounding, a
    convex combination of its corners) touches those colliders."""
    grow = SLACK * (abs(lx) + abs(ly) + abs(lz) + abs(hx) + abs(hy) + abs(hz))
    lx -= grow
    ly -= grow
    lz -= grow
    hx += grow
    hy += grow
    hz += grow
    for k in range(boxes.shape[0]):
        if not (lx > boxes[k, 3] or hx < boxes[k, 0] or ly > boxes[k, 4] or hy < boxes[k, 1] or lz > boxes[k, 5] or hz < boxes[k, 2]):
            return False
    return True


@kernel(device=True)
def segment_distance(px, py, pz, ax, ay, az, bx, by, bz):
    """Distance of p from the segment ab (float64)."""
    ex = bx - ax
    ey = by - ay
    ez = bz - az
    dx = px - ax
    dy = py - ay
    dz = pz - az
    length2 = ex * ex + ey * ey + ez * ez
    t = 0.0
    if length2 > 0.0:
        t = min(max((dx * ex + dy * ey + dz * ez) / length2, 0.0), 1.0)
    dx -= t * ex
    dy -= t * ey
    dz -= t * ez
    return np.sqrt(dx * dx + dy * dy + dz * dz)


@kernel(device=True)
def _far(gap, scale):
    """True when ``gap`` (a distance minus the reach) is positive beyond rounding of ``scale``."""
    return gap > SLACK * scale


@kernel(device=True)
def spheres_far(cx, cy, cz, radius, sphere_data, swept):
    """True when the ball (c, radius) is beyond reach of every sphere (``swept``: over the
    sphere's motion through the iteration, for continuous collision)."""
    S = sphere_data
    magnitude = abs(cx) + abs(cy) + abs(cz) + radius
    for s in range(S.shape[0]):
        x1, y1, z1, r1 = np.float64(S[s, 4]), np.float64(S[s, 5]), np.float64(S[s, 6]), np.float64(S[s, 7])
        scale = magnitude + abs(x1) + abs(y1) + abs(z1) + abs(r1)
        if swept:
            x0, y0, z0, r0 = np.float64(S[s, 0]), np.float64(S[s, 1]), np.float64(S[s, 2]), np.float64(S[s, 3])
            distance = segment_distance(cx, cy, cz, x0, y0, z0, x1, y1, z1)
            scale += abs(x0) + abs(y0) + abs(z0) + abs(r0)
            reach = max(r0, r1)
        else:
            dx, dy, dz = cx - x1, cy - y1, cz - z1
            distance = np.sqrt(dx * dx + dy * dy + dz * dz)
            reach = r1
        if not _far(distance - radius - reach, scale):
            return False
    return True


@kernel(device=True)
def capsules_far(cx, cy, cz, radius, capsule_data, swept):
    """As spheres_far, for the capsules (see the module docstring)."""
    C = capsule_data
    magnitude = abs(cx) + abs(cy) + abs(cz) + radius
    for c in range(C.shape[0]):
        a1x, a1y, a1z, ra1 = np.float64(C[c, 8]), np.float64(C[c, 9]), np.float64(C[c, 10]), np.float64(C[c, 11])
        b1x, b1y, b1z, rb1 = np.float64(C[c, 12]), np.float64(C[c, 13]), np.float64(C[c, 14]), np.float64(C[c, 15])
        d1 = segment_distance(cx, cy, cz, a1x, a1y, a1z, b1x, b1y, b1z)
        scale = magnitude + abs(a1x) + abs(a1y) + abs(a1z) + abs(b1x) + abs(b1y) + abs(b1z) + abs(ra1) + abs(rb1)
        reach = max(ra1, rb1)
        distance = d1
        if swept:
            a0x, a0y, a0z, ra0 = np.float64(C[c, 0]), np.float64(C[c, 1]), np.float64(C[c, 2]), np.float64(C[c, 3])
            b0x, b0y, b0z, rb0 = np.float64(C[c, 4]), np.float64(C[c, 5]), np.float64(C[c, 6]), np.float64(C[c, 7])
            d0 = segment_distance(cx, cy, cz, a0x, a0y, a0z, b0x, b0y, b0z)
            travel_a = np.sqrt((a1x - a0x) ** 2 + (a1y - a0y) ** 2 + (a1z - a0z) ** 2)
            travel_b = np.sqrt((b1x - b0x) ** 2 + (b1y - b0y) ** 2 + (b1z - b0z) ** 2)
            distance = 0.5 * (d0 + d1 - max(travel_a, travel_b))
            scale += abs(a0x) + abs(a0y) + abs(a0z) + abs(b0x) + abs(b0y) + abs(b0z) + abs(ra0) + abs(rb0)
            # capsule_time_of_impact reports a touch within its tolerance of the surface
            reach = max(reach, ra0, rb0) + impact_tolerance(max(ra0, rb0, ra1, rb1))
        if not _far(distance - radius - reach, scale):
            return False
    return True


@kernel(device=True)
def convexes_far(cx, cy, cz, radius, planes, offsets, convex_data):
    """True when every convex has a plane with the whole ball outside it, beyond the margin."""
    magnitude = abs(cx) + abs(cy) + abs(cz) + radius
    for k in range(offsets.shape[0] - 1):
        margin = np.float64(convex_data[k, 0])
        separated = offsets[k + 1] <= offsets[k]  # no planes: convex_distance is +inf
        for j in range(offsets[k], offsets[k + 1]):
            nx, ny, nz, d = np.float64(planes[j, 0]), np.float64(planes[j, 1]), np.float64(planes[j, 2]), np.float64(planes[j, 3])
            length = np.sqrt(nx * nx + ny * ny + nz * nz)
            gap = nx * cx + ny * cy + nz * cz - d - margin - radius * length
            scale = (magnitude + abs(margin)) * (length + 1.0) + abs(d)
            if _far(gap, scale):
                separated = True
                break
        if not separated:
            return False
    return True


@kernel(device=True)
def mesh_far(cx, cy, cz, radius, cell_start, grid, frame):
    """True when the grid cells covered by the ball's world boxes at the frame's start and
    end poses are all empty (or outside the grid)."""
    x0, y0, z0 = to_world(frame, 0, cx, cy, cz)
    x1, y1, z1 = to_world(frame, 1, cx, cy, cz)
    magnitude = abs(x0) + abs(y0) + abs(z0) + abs(x1) + abs(y1) + abs(z1) + abs(cx) + abs(cy) + abs(cz) + radius
    grow = radius + SLACK * magnitude
    outside, i0, j0, k0, i1, j1, k1 = box_cells(
        min(x0, x1) - grow, min(y0, y1) - grow, min(z0, z1) - grow,
        max(x0, x1) + grow, max(y0, y1) + grow, max(z0, z1) + grow, grid,
    )
    if outside:
        return True
    nx = int(grid[4])
    ny = int(grid[5])
    for k in range(k0, k1 + 1):
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                cell = (k * ny + j) * nx + i
                if cell_start[cell + 1] > cell_start[cell]:
                    return False
    return True
