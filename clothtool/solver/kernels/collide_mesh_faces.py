"""Face collision against triangle-mesh colliders: the collider's points against the cloth's faces.

Particle collision keeps the cloth's particles outside a mesh, but a mesh's corners and
ridges (a low-poly body's knee, the edge of a box) can still poke through a cloth face
between particles. So each cloth triangle is also collided with the collider's *points*: its
vertices and samples along its edges (clothtool.solver.meshfaces chooses them). The roles of
clothtool.solver.kernels.collide_mesh are swapped: the cloth triangle, from its corners'
previous to current positions, is the moving triangle record (pack_triangle), the collider
point moving from its start to its end pose is the moving point, and triangle_contact_within
decides the contact with the same side rules (the side is the one the point was on at the
iteration's start, crossings through the face are caught), with the collider's margin. The
point's push-out d is the cloth's correction with the opposite sign, applied as a
point-triangle constraint against an immovable point: with barycentric weights b of the
contact point and inverse masses w (zero for a corner that cannot move), corner i moves by
-d b_i w_i / sum_j b_j^2 w_j, so the contact point moves by exactly -d. Friction (Coulomb, as
for particles: clothtool.solver.kernels.collide.friction_correction) acts on the contact
point's motion relative to the collider point's, and the collision mass scale on the corners'
inverse masses weighted by b (as for virtual particles).

Of all the points a cloth triangle touches only the one with the largest push-out counts (as
a particle keeps its deepest triangle), and triangles are processed in order, each seeing the
corrections before it (Gauss-Seidel: a point under an edge shared by two triangles is pushed
out once).

Candidates come from the collider's world-space triangle grid (collide_mesh): the cells of
the box of the cloth triangle's world corners at the iteration's start and end, each
collider triangle visited once (in the first cell both boxes share). Each collider point is
owned by one triangle, which tests it: ``owners`` (t,4) i32 holds per triangle a bit mask of
the corners it owns (bit 0-2: a, b, c) and the number of samples, spaced evenly, inside each
of its edges ab, bc, ca (columns 1-3; zero for an edge another triangle owns).
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel
from clothtool._minmax import largest, smallest
from clothtool.solver.kernels.collide import friction_correction
from clothtool.solver.kernels.collide_mesh import (
    box_cell,
    box_cell_count,
    box_cells,
    first_shared_cell,
    to_world,
    triangle_contact_within,
)
from clothtool.solver.kernels.collide_pose import pack_triangle


@kernel(inline="always")
def _collider_point(T, t, k, owners):
    """(ok, qx, qy, qz, px, py, pz): point k of collider triangle t at the iteration's start
    and end (k 0-2: corners a, b, c; k >= 3: edge samples, edge by edge), ok False for a
    corner t does not own."""
    zero = np.float32(0.0)
    if k < 3:
        if not (owners[t, 0] >> k) & 1:
            return False, zero, zero, zero, zero, zero, zero
        o = 3 * k
        return True, T[t, o], T[t, o + 1], T[t, o + 2], T[t, 9 + o], T[t, 10 + o], T[t, 11 + o]
    k -= 3
    for edge in range(3):
        n = owners[t, 1 + edge]
        if k < n:
            s = (k + 1) / (n + 1)
            r = 1.0 - s
            i = 3 * edge
            j = 3 * ((edge + 1) % 3)
            return (
                True,
                r * T[t, i] + s * T[t, j], r * T[t, i + 1] + s * T[t, j + 1], r * T[t, i + 2] + s * T[t, j + 2],
                r * T[t, 9 + i] + s * T[t, 9 + j], r * T[t, 10 + i] + s * T[t, 10 + j],
                r * T[t, 11 + i] + s * T[t, 11 + j],
            )
        k -= n
    return False, zero, zero, zero, zero, zero, zero


@kernel(inline="always")
def _misses(R, T, t):
    """True when no point of collider triangle t can touch the cloth triangle of record R
    (row 0): its points are convex combinations of its corners, so their heights over the
    cloth's planes lie between the corners'. With every corner on one side of the start
    plane, no point is within the margin when all are beyond it at the end, and no point
    crosses when all stay on their side, leaving only contacts near the face, inside the
    face's box grown by the margin, which the collider triangle's own box must then meet."""
    zero = np.float32(0.0)
    low0 = low1 = np.inf
    high0 = high1 = -np.inf
    for k in range(3):
        o = 3 * k
        h0 = R[0, 18] * (T[t, o] - R[0, 0]) + R[0, 19] * (T[t, o + 1] - R[0, 1]) + R[0, 20] * (T[t, o + 2] - R[0, 2])
        h1 = R[0, 21] * (T[t, 9 + o] - R[0, 9]) + R[0, 22] * (T[t, 10 + o] - R[0, 10]) + R[0, 23] * (T[t, 11 + o] - R[0, 11])
        low0 = smallest(low0, h0)
        high0 = largest(high0, h0)
        low1 = smallest(low1, h1)
        high1 = largest(high1, h1)
    margin = T[t, 24]
    if low0 >= zero:
        if low1 >= margin:
            return True
        near = low1 >= zero
    elif high0 < zero:
        if high1 <= -margin:
            return True
        near = high1 < zero
    else:
        return False
    if not near:
        return False
    for d in range(3):  # the boxes (each grown by a margin) are apart
        if T[t, 26 + d] > R[0, 29 + d] or T[t, 29 + d] < R[0, 26 + d]:
            return True
    return False


@kernel
def collide_mesh_faces(
    cloth_triangles, owners, triangle_data, cell_start, cell_items, cell_ranges, grid, frame, prev,
    margin, mass_scale, meters_per_unit, record, cur,
):
    """Collide each cloth triangle (i32 (f,3) particle indices) with the collider points near
    it (see the module docstring); prev/cur (n,4) particle states, positions and inverse
    masses; ``margin``: the largest collider margin (the records' boxes are grown by it);
    ``record`` (1,32) scratch for the cloth triangle's record. Returns the number of cloth
    triangles corrected."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    T = triangle_data
    corrected = 0
    for f in range(cloth_triangles.shape[0]):
        a = cloth_triangles[f, 0]
        b = cloth_triangles[f, 1]
        c = cloth_triangles[f, 2]
        wa = cur[a, 3] if prev[a, 3] > zero else zero
        wb = cur[b, 3] if prev[b, 3] > zero else zero
        wc = cur[c, 3] if prev[c, 3] > zero else zero
        if wa <= zero and wb <= zero and wc <= zero:
            continue
        # the world box of the corners at the iteration's start and end
        lo0 = lo1 = lo2 = np.inf
        hi0 = hi1 = hi2 = -np.inf
        for p in (a, b, c):
            for end in range(2):
                if end == 0:
                    x, y, z = to_world(frame, 0, prev[p, 0], prev[p, 1], prev[p, 2])
                else:
                    x, y, z = to_world(frame, 1, cur[p, 0], cur[p, 1], cur[p, 2])
                lo0 = smallest(lo0, x)
                lo1 = smallest(lo1, y)
                lo2 = smallest(lo2, z)
                hi0 = largest(hi0, x)
                hi1 = largest(hi1, y)
                hi2 = largest(hi2, z)
        outside, x0, y0, z0, x1, y1, z1 = box_cells(lo0, lo1, lo2, hi0, hi1, hi2, grid)
        if outside:
            continue
        pack_triangle(prev, cur, a, b, c, margin, zero, record, 0)
        best = zero
        hit = False
        dx = dy = dz = u = v = zero
        sx = sy = sz = mu = zero
        for n in range(box_cell_count(x0, y0, z0, x1, y1, z1)):
            x, y, z, cell = box_cell(n, x0, y0, z0, x1, y1, z1, grid)
            for e in range(cell_start[cell], cell_start[cell + 1]):
                t = cell_items[e]
                if not first_shared_cell(t, x, y, z, x0, y0, z0, cell_ranges):
                    continue  # visit each collider triangle once
                if _misses(record, T, t):
                    continue
                points = 3 + owners[t, 1] + owners[t, 2] + owners[t, 3]
                for k in range(points):
                    ok, qx, qy, qz, px, py, pz = _collider_point(T, t, k, owners)
                    if not ok:
                        continue
                    ok, ex, ey, ez, eu, ev = triangle_contact_within(px, py, pz, qx, qy, qz, record, 0, T[t, 24])
                    if not ok:
                        continue
                    size = ex * ex + ey * ey + ez * ez
                    if size > best:
                        best = size
                        hit = True
                        dx, dy, dz, u, v = ex, ey, ez, eu, ev
                        sx, sy, sz = px - qx, py - qy, pz - qz
                        mu = T[t, 25]
        if not hit:
            continue
        # the contact point on the cloth triangle and the immovable point's push-out, reversed
        ba = one - u - v
        ma = ba * wa
        mb = u * wb
        mc = v * wc
        norm = ba * ma + u * mb + v * mc
        if norm <= zero:
            continue  # the contact is at corners that cannot move
        cx = ba * cur[a, 0] + u * cur[b, 0] + v * cur[c, 0] - dx
        cy = ba * cur[a, 1] + u * cur[b, 1] + v * cur[c, 1] - dy
        cz = ba * cur[a, 2] + u * cur[b, 2] + v * cur[c, 2] - dz
        qx = ba * prev[a, 0] + u * prev[b, 0] + v * prev[c, 0]
        qy = ba * prev[a, 1] + u * prev[b, 1] + v * prev[c, 1]
        qz = ba * prev[a, 2] + u * prev[b, 2] + v * prev[c, 2]
        fx, fy, fz = friction_correction(cx, cy, cz, qx, qy, qz, -dx, -dy, -dz, sx, sy, sz, mu * np.sqrt(best))
        kx = fx - dx
        ky = fy - dy
        kz = fz - dz
        scale = one
        if mass_scale > 0.0:
            scale = one / (one + mass_scale * best * meters_per_unit * meters_per_unit)
        for p, m, weight in ((a, ma, ba), (b, mb, u), (c, mc, v)):
            if m <= zero:
                continue
            share = m / norm
            cur[p, 0] += kx * share
            cur[p, 1] += ky * share
            cur[p, 2] += kz * share
            cur[p, 3] *= one + (scale - one) * weight
        corrected += 1
    return corrected
