"""Face collision with spheres and capsules: each triangle's deepest point, corrected once.

Particle collision alone lets a sphere or capsule sink into a face between particles
(clothtool.solver.facepoints picks the triangles large enough for that). For each such
triangle and each sphere or capsule whose box meets the triangle's, ``collide_faces`` finds
the triangle's deepest point against that collider (its point of least signed distance)
and, when it is inside, collides that one point like a particle: push-out to the margin,
friction, collision mass scale (kernels.collide). Its correction c is shared out to the
movable corners as x_i += c w_i / sum(w^2) (w: the point's barycentric weights, the sum over
the movable corners), so the point itself moves by c: the rule of the fabric's virtual
particles (kernels.collide.collide_virtual). Unlike theirs, the deepest point may sit next to
a pinned corner, where w_i / sum(w^2) grows without bound (c / w_i for a lone movable corner
of weight w_i): the share is capped at (1 + sqrt 3) / 2, the largest it reaches when every
corner can move (at w = 1/sqrt 3 with the other two equal), so a face of movable corners
follows the rule exactly and a face pinned at the contact moves its free corners at most
that many times c (the point then moves less than c: a pinned particle inside a collider
cannot be helped).
Once the deepest point is out, the whole face is; one exact point per face and collider does
what a grid of points inside every face did at several times the cost. Triangles and then
colliders are taken in order, each seeing the corrections before it (Gauss-Seidel, serial:
the same bits at any thread count).

The deepest point of triangle T. A capsule (collide_shapes) is the union of the spheres
c(s) = a + s u, r(s) = ra - s sin(alpha) for s in [0, L], so its signed distance is
sd(x) = min over s of |x - c(s)| - r(s), and min over T of sd is the minimum of that jointly
convex function over (x in T, s in [0, L]). At a minimiser either

* s is an end (0 or L): x is T's closest point to that end sphere's centre; or
* s is inside: minimising over s alone gives the cone G(x) = cos(alpha) rho(x) + sin(alpha) t(x)
  - ra (rho: distance from the axis line, t: axial coordinate; collide_shapes' side distance).
  On T's plane G has no minimum inside T except where the axis line crosses the plane: its
  gradient cos(alpha) e + sin(alpha) u is normal to the plane only where u.N = +-sin(alpha),
  and then G is constant along a line that runs on to T's edges. So x is the crossing point
  or on an edge, where G along the edge is cos(alpha) sqrt(A y^2 + m^2) + k y + const, whose
  minimiser has a closed form (``_edge_minimum``).

The deepest point is thus the best of at most six candidates (the two end spheres, tried only
when T reaches that far along the axis, three edges, the crossing), each scored with
collide_shapes.capsule_distance itself, so the depth used is the exact one at that point. A
sphere's deepest point is T's closest point to its centre.
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel
from clothtool._minmax import largest, smallest
from clothtool.solver.kernels.collide import friction_correction, movable_weights, share_out, weighted_point
from clothtool.solver.kernels.collide_mesh import closest_on_triangle
from clothtool.solver.kernels.collide_shapes import capsule_distance, sphere_distance

# An edge within ~0.06 degrees of the capsule's axis counts as parallel to it: G is then
# linear along the edge (to micrometres over centimetre edges) and an end of it is deepest.
PARALLEL = np.float32(1e-6)
# The largest share w_i / sum(w^2) of a correction when all three corners move (module docstring).
MAX_SHARE = np.float32((1.0 + np.sqrt(3.0)) / 2.0)


@kernel(inline="always")
def _capsule_terms(C, c):
    """Capsule c's end pose and axis terms (collide_shapes.capsule_axis) as a tuple of
    scalars: ax, ay, az, ra, bx, by, bz, rb, ux, uy, uz, L, sin(alpha), cos(alpha), reach^2
    (a tuple of scalars passes to a helper without an array's reference counting)."""
    return (C[c, 8], C[c, 9], C[c, 10], C[c, 11], C[c, 12], C[c, 13], C[c, 14], C[c, 15], C[c, 17], C[c, 18], C[c, 19],
            C[c, 20], C[c, 21], C[c, 22], C[c, 23])


@kernel(inline="always")
def _side(t, rho2, T):
    """G = cos(alpha) rho + sin(alpha) t - ra of a point at axial t, squared distance rho2
    from the axis line, when its closest sphere lies inside the axis (0 < s < L, s cos(alpha) =
    t cos(alpha) - rho sin(alpha)): then it is the capsule's signed distance there; else inf
    (an end sphere is closest, and the end candidates cover that)."""
    ax, ay, az, ra, bx, by, bz, rb, ux, uy, uz, length, sin_a, cos_a, reach2 = T
    rho = np.sqrt(rho2)
    s = t * cos_a - rho * sin_a
    if s <= 0.0 or s >= length * cos_a:
        return np.float32(np.inf)
    return cos_a * rho + sin_a * t - ra


@kernel(inline="always")
def _edge_minimum(px, py, pz, qx, qy, qz, T):
    """(G, lambda): where along the edge p + lambda (q - p), lambda in [0, 1], the cone
    function G = cos(alpha) rho + sin(alpha) t - ra is least (see the module docstring), and
    G there (``_side``: inf when an end sphere is closest there).

    With e = q - p split into its axial part te and its part we across the axis, and
    w0 = (p - a) across the axis: rho^2 = A y^2 + m^2 with A = |we|^2, y = lambda - lambda0,
    lambda0 = -w0.we / A, and G' = 0 where cos(alpha) A y / rho = -k, k = sin(alpha) te:
    y = -k m / sqrt(A (A cos^2(alpha) - k^2)); G is monotonic when A cos^2(alpha) <= k^2."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    ax, ay, az, ra, bx, by, bz, rb, ux, uy, uz, length, sin_a, cos_a, reach2 = T
    ex, ey, ez = qx - px, qy - py, qz - pz
    te = ex * ux + ey * uy + ez * uz
    wex, wey, wez = ex - te * ux, ey - te * uy, ez - te * uz
    dx, dy, dz = px - ax, py - ay, pz - az
    t0 = dx * ux + dy * uy + dz * uz
    w0x, w0y, w0z = dx - t0 * ux, dy - t0 * uy, dz - t0 * uz
    big_a = wex * wex + wey * wey + wez * wez
    k = sin_a * te
    lam = one if k < zero else zero  # the lower end when G is linear or monotonic along the edge
    if big_a > PARALLEL * (ex * ex + ey * ey + ez * ez):
        lambda0 = -(w0x * wex + w0y * wey + w0z * wez) / big_a
        slope = big_a * cos_a * cos_a - k * k
        if slope > zero:
            m2 = largest(w0x * w0x + w0y * w0y + w0z * w0z - big_a * lambda0 * lambda0, zero)
            lam = smallest(largest(lambda0 - k * np.sqrt(m2 / (big_a * slope)), zero), one)
    wx, wy, wz = w0x + lam * wex, w0y + lam * wey, w0z + lam * wez
    return _side(t0 + lam * te, wx * wx + wy * wy + wz * wz, T), lam


@kernel(inline="always")
def _end_sphere(cx, cy, cz, r, p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z):
    """(|x - c| - r, weights of x): the triangle's point x closest to the sphere's centre c."""
    u, v = closest_on_triangle(cx, cy, cz, p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z)
    w = np.float32(1.0) - u - v
    dx = w * p0x + u * p1x + v * p2x - cx
    dy = w * p0y + u * p1y + v * p2y - cy
    dz = w * p0z + u * p1z + v * p2z - cz
    return np.sqrt(dx * dx + dy * dy + dz * dz) - r, w, u, v


@kernel(inline="always")
def capsule_deepest(p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z, T, exact):
    """(g, wa, wb, wc): the deepest point of triangle p0 p1 p2 against the capsule of terms T
    (_capsule_terms) as barycentric weights w, and the capsule's signed distance g there (from
    the candidates' own arithmetic: collide_faces takes collide_shapes.capsule_distance's).

    Each candidate of the module docstring is scored cheaply: an end sphere's by the distance
    from it (not less than the capsule's), an edge's or the crossing's by G when the
    capsule's closest sphere there lies inside the axis (then G is the capsule's distance;
    otherwise an end candidate covers it). The least score is the triangle's least distance
    and its candidate a point where it is reached.

    Without ``exact`` (a constant: the collision) a triangle with no point inside the capsule
    may give g = inf, and end spheres beyond the capsule's reach are not tried; with it (the
    measurement, clothtool.solver.kernels.penetration_shapes) every candidate is scored, so g
    is the least distance also when it is positive (the clearance)."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    ax, ay, az, ra, bx, by, bz, rb, ux, uy, uz, length, sin_a, cos_a, reach2 = T
    if length < zero:  # one end sphere holds the other: the capsule is the bigger one
        if ra >= rb:
            best, wa, wb, wc = _end_sphere(ax, ay, az, ra, p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z)
        else:
            best, wa, wb, wc = _end_sphere(bx, by, bz, rb, p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z)
    else:
        d0x, d0y, d0z = p0x - ax, p0y - ay, p0z - az
        d1x, d1y, d1z = p1x - ax, p1y - ay, p1z - az
        d2x, d2y, d2z = p2x - ax, p2y - ay, p2z - az
        t0 = d0x * ux + d0y * uy + d0z * uz
        t1 = d1x * ux + d1y * uy + d1z * uz
        t2 = d2x * ux + d2y * uy + d2z * uz
        # cheap rejection first: the capsule lies within max(ra, rb) of its axis line, and on
        # the triangle rho^2 = sum w_i rho_i^2 - sum_{i<j} w_i w_j |P(p_i - p_j)|^2 (P: across
        # the axis) is at least min rho_i^2 - max |P(p_i - p_j)|^2 / 3 (sum_{i<j} w_i w_j <= 1/3).
        # Most faces near a capsule are not in it: this skips about half of them
        q0 = d0x * d0x + d0y * d0y + d0z * d0z - t0 * t0
        q1 = d1x * d1x + d1y * d1y + d1z * d1z - t1 * t1
        q2 = d2x * d2x + d2y * d2y + d2z * d2z - t2 * t2
        e01 = (d1x - d0x) ** 2 + (d1y - d0y) ** 2 + (d1z - d0z) ** 2 - (t1 - t0) ** 2
        e12 = (d2x - d1x) ** 2 + (d2y - d1y) ** 2 + (d2z - d1z) ** 2 - (t2 - t1) ** 2
        e20 = (d0x - d2x) ** 2 + (d0y - d2y) ** 2 + (d0z - d2z) ** 2 - (t0 - t2) ** 2
        r = largest(ra, rb)
        if not exact and smallest(q0, q1, q2) - largest(e01, e12, e20) * np.float32(1.0 / 3.0) > r * r:
            return np.float32(np.inf), one, zero, zero
        # the edges
        best, s = _edge_minimum(p0x, p0y, p0z, p1x, p1y, p1z, T)
        wa, wb, wc = one - s, s, zero
        g, s = _edge_minimum(p1x, p1y, p1z, p2x, p2y, p2z, T)
        if g < best:
            best, wa, wb, wc = g, zero, one - s, s
        g, s = _edge_minimum(p2x, p2y, p2z, p0x, p0y, p0z, T)
        if g < best:
            best, wa, wb, wc = g, s, zero, one - s
        # where the axis line crosses the triangle: its barycentric weights are the volumes
        # u . (d1 x d2), u . (d2 x d0), u . (d0 x d1) (d_i = p_i - a), all of one sign inside
        v0 = ux * (d1y * d2z - d1z * d2y) + uy * (d1z * d2x - d1x * d2z) + uz * (d1x * d2y - d1y * d2x)
        v1 = ux * (d2y * d0z - d2z * d0y) + uy * (d2z * d0x - d2x * d0z) + uz * (d2x * d0y - d2y * d0x)
        v2 = ux * (d0y * d1z - d0z * d1y) + uy * (d0z * d1x - d0x * d1z) + uz * (d0x * d1y - d0y * d1x)
        if (v0 >= zero and v1 >= zero and v2 >= zero) or (v0 <= zero and v1 <= zero and v2 <= zero):
            total = v0 + v1 + v2
            if total != zero:
                c0, c1, c2 = v0 / total, v1 / total, v2 / total
                t = ((c0 * d0x + c1 * d1x + c2 * d2x) * ux + (c0 * d0y + c1 * d1y + c2 * d2y) * uy
                     + (c0 * d0z + c1 * d1z + c2 * d2z) * uz)
                g = _side(t, zero, T)
                if g < best:
                    best, wa, wb, wc = g, c0, c1, c2
        # the end spheres, when the triangle reaches their side of the cone: s = t - rho tan(alpha)
        # is at least min t - reach |tan(alpha)| over the points within reach (rho <= reach)
        slant = np.sqrt(reach2) * abs(sin_a)  # reach |tan(alpha)|, times cos(alpha)
        if exact or smallest(t0, t1, t2) * cos_a <= slant:
            g, ea, eb, ec = _end_sphere(ax, ay, az, ra, p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z)
            if g < best:
                best, wa, wb, wc = g, ea, eb, ec
        if exact or (largest(t0, t1, t2) - length) * cos_a >= -slant:
            g, ea, eb, ec = _end_sphere(bx, by, bz, rb, p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z)
            if g < best:
                best, wa, wb, wc = g, ea, eb, ec
    return best, wa, wb, wc


@kernel(inline="always")
def _correct(cur, prev, a, b, c, wa, wb, wc, d, nx, ny, nz, sx, sy, sz, friction, mass_scale, meters_per_unit):
    """Collide the point w of triangle abc, ``-d`` inside along the outward normal n, on a
    surface that moved by s over the iteration (see the module docstring)."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    ma, mb, mc, norm = movable_weights(cur, prev, a, b, c, wa, wb, wc)
    if norm <= zero:
        return
    px, py, pz = weighted_point(cur, a, b, c, wa, wb, wc)
    qx, qy, qz = weighted_point(prev, a, b, c, wa, wb, wc)
    dx, dy, dz = -d * nx, -d * ny, -d * nz
    fx, fy, fz = friction_correction(px + dx, py + dy, pz + dz, qx, qy, qz, dx, dy, dz, sx, sy, sz, -friction * d)
    cx, cy, cz = dx + fx, dy + fy, dz + fz
    scale = one
    if mass_scale > 0.0:
        square = (dx * dx + dy * dy + dz * dz) * meters_per_unit * meters_per_unit
        scale = one / (one + mass_scale * square)
    share_out(cur, a, b, c, ma, mb, mc, norm, cx, cy, cz, scale, MAX_SHARE)


@kernel(device=True)
def _collider_boxes(sphere_data, capsule_data, out):
    """out (s+c, 6): lo xyz, hi xyz of each sphere, then each capsule, at the end pose: every
    point inside it lies in its box."""
    S, C = sphere_data, capsule_data
    for s in range(S.shape[0]):
        for d in range(3):
            out[s, d] = S[s, 4 + d] - S[s, 7]
            out[s, 3 + d] = S[s, 4 + d] + S[s, 7]
    for c in range(C.shape[0]):
        r = largest(C[c, 11], C[c, 15])
        k = S.shape[0] + c
        for d in range(3):
            out[k, d] = smallest(C[c, 8 + d], C[c, 12 + d]) - r
            out[k, 3 + d] = largest(C[c, 8 + d], C[c, 12 + d]) + r


@kernel
def collide_faces(faces, sphere_data, capsule_data, prev, mass_scale, meters_per_unit, cur):
    """Collide the deepest point of every triangle of ``faces`` (f,3) with every sphere and
    capsule whose box meets the triangle's, in order (see the module docstring)."""
    S, C = sphere_data, capsule_data
    spheres = S.shape[0]
    boxes = np.empty((spheres + C.shape[0], 6), cur.dtype)
    _collider_boxes(S, C, boxes)
    for f in range(faces.shape[0]):
        a = faces[f, 0]
        b = faces[f, 1]
        c = faces[f, 2]
        moved = True
        for k in range(boxes.shape[0]):
            if moved:  # the corners and their box, again after a correction
                moved = False
                p0x, p0y, p0z = cur[a, 0], cur[a, 1], cur[a, 2]
                p1x, p1y, p1z = cur[b, 0], cur[b, 1], cur[b, 2]
                p2x, p2y, p2z = cur[c, 0], cur[c, 1], cur[c, 2]
                lx, ly, lz = smallest(p0x, p1x, p2x), smallest(p0y, p1y, p2y), smallest(p0z, p1z, p2z)
                hx, hy, hz = largest(p0x, p1x, p2x), largest(p0y, p1y, p2y), largest(p0z, p1z, p2z)
            if (lx > boxes[k, 3] or hx < boxes[k, 0] or ly > boxes[k, 4] or hy < boxes[k, 1] or lz > boxes[k, 5]
                    or hz < boxes[k, 2]):
                continue
            if k < spheres:
                u, v = closest_on_triangle(S[k, 4], S[k, 5], S[k, 6], p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z)
                wa, wb, wc = np.float32(1.0) - u - v, u, v
                d, nx, ny, nz = sphere_distance(wa * p0x + wb * p1x + wc * p2x, wa * p0y + wb * p1y + wc * p2y,
                                                wa * p0z + wb * p1z + wc * p2z, S[k, 4], S[k, 5], S[k, 6], S[k, 7])
                if d < 0.0:
                    moved = True
                    _correct(cur, prev, a, b, c, wa, wb, wc, d, nx, ny, nz, S[k, 4] - S[k, 0], S[k, 5] - S[k, 1],
                             S[k, 6] - S[k, 2], S[k, 8], mass_scale, meters_per_unit)
                continue
            j = k - spheres
            g, wa, wb, wc = capsule_deepest(p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z, _capsule_terms(C, j), False)
            if not g < 0.0:
                continue
            # the response takes the capsule's own distance and normal there (the particles')
            d, nx, ny, nz, sigma = capsule_distance(wa * p0x + wb * p1x + wc * p2x, wa * p0y + wb * p1y + wc * p2y,
                                                    wa * p0z + wb * p1z + wc * p2z, C, j)
            if d < 0.0:
                moved = True
                w = np.float32(1.0) - sigma  # the surface's motion: the end spheres' interpolated at sigma
                _correct(cur, prev, a, b, c, wa, wb, wc, d, nx, ny, nz,
                         w * (C[j, 8] - C[j, 0]) + sigma * (C[j, 12] - C[j, 4]),
                         w * (C[j, 9] - C[j, 1]) + sigma * (C[j, 13] - C[j, 5]),
                         w * (C[j, 10] - C[j, 2]) + sigma * (C[j, 14] - C[j, 6]), C[j, 16], mass_scale, meters_per_unit)
