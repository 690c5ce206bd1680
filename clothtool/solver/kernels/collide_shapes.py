"""Collision geometry of spheres, capsules (tapered cones) and convexes, point by point.

Device functions called by the collide kernels for every particle (and virtual particle).
Radii and plane offsets here already include the margin (collider thickness plus the cloth's
thickness), so a contact is a negative distance and its push-out is ``-distance * normal``.

Packed records (one row per primitive, float32; the stage fills them each iteration):

    sphere_data  (s, 9):  x0 y0 z0 r0  x1 y1 z1 r1  friction       start and end pose
    capsule_data (c, 24): a0 ra0 b0 rb0 a1 ra1 b1 rb1 friction       (a, b: xyz end centres)
                          then the end pose's axis terms (capsule_axis): u xyz, L, sin(alpha),
                          cos(alpha), and the square of the reach beyond which no point touches

Capsule = the convex hull of two spheres (a, ra) and (b, rb), which is also the union of the
spheres interpolated linearly between them. With axis length L, unit axis u and
sin(alpha) = (ra - rb) / L, the hull's side is a cone whose outward normal makes the angle
alpha with the radial direction e: n = sin(alpha) u + cos(alpha) e. In the half-plane of the
axis and the point (axial coordinate x, radial distance r), the side line touches sphere a at
line coordinate s = x cos(alpha) - r sin(alpha) = 0 and sphere b at s = L cos(alpha): a point
with s < 0 is closest to sphere a, with s > L cos(alpha) to sphere b, else to the side, where
its signed distance is x sin(alpha) + r cos(alpha) - ra. This is exact inside and outside.
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel
from clothtool._minmax import largest, smallest

TINY = np.float32(1e-12)


@kernel(device=True)
def perpendicular(ux, uy, uz):
    """A unit vector perpendicular to unit u: u x e_k for the coordinate axis e_k that u is
    least aligned with (the first one on ties), normalised."""
    ax, ay, az = abs(ux), abs(uy), abs(uz)
    if ax <= ay and ax <= az:
        px, py, pz = np.float32(0.0), uz, -uy
    elif ay <= az:
        px, py, pz = -uz, np.float32(0.0), ux
    else:
        px, py, pz = uy, -ux, np.float32(0.0)
    length = np.sqrt(px * px + py * py + pz * pz)
    return px / length, py / length, pz / length


@kernel(device=True)
def sphere_distance(px, py, pz, cx, cy, cz, radius):
    """(distance, nx, ny, nz): signed distance of p from the sphere and the outward unit normal
    at its closest surface point (+y when p is at the centre)."""
    dx = px - cx
    dy = py - cy
    dz = pz - cz
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    if length <= TINY:
        return -radius, np.float32(0.0), np.float32(1.0), np.float32(0.0)
    inv = np.float32(1.0) / length
    return length - radius, dx * inv, dy * inv, dz * inv


@kernel(device=True)
def round_cone_distance(px, py, pz, ax, ay, az, ra, bx, by, bz, rb):
    """(distance, nx, ny, nz, sigma) of p from the hull of spheres (a, ra) and (b, rb).

    sigma in [0,1] locates the contact along the capsule: the interpolated sphere
    a + sigma (b - a) with radius ra + sigma (rb - ra) is the one whose surface holds the
    closest point (0 and 1 on the end caps). When one sphere holds the other the capsule is
    the bigger sphere.
    """
    zero = np.float32(0.0)
    one = np.float32(1.0)
    abx = bx - ax
    aby = by - ay
    abz = bz - az
    length = np.sqrt(abx * abx + aby * aby + abz * abz)
    if length <= abs(ra - rb) or length <= TINY:
        if ra >= rb:
            d, nx, ny, nz = sphere_distance(px, py, pz, ax, ay, az, ra)
            return d, nx, ny, nz, zero
        d, nx, ny, nz = sphere_distance(px, py, pz, bx, by, bz, rb)
        return d, nx, ny, nz, one
    inv_length = one / length
    ux = abx * inv_length
    uy = aby * inv_length
    uz = abz * inv_length
    sin_a = (ra - rb) * inv_length
    cos_a = np.sqrt(largest(one - sin_a * sin_a, zero))
    axial, ex, ey, ez, radial2 = _axial_and_radial(px, py, pz, ax, ay, az, ux, uy, uz)
    return _cone_distance(px, py, pz, ax, ay, az, ra, bx, by, bz, rb, ux, uy, uz, length, sin_a, cos_a, axial, ex, ey, ez,
                          radial2)


@kernel(inline="always")
def _axial_and_radial(px, py, pz, ax, ay, az, ux, uy, uz):
    """(axial, ex, ey, ez, radial^2): p - a along the unit axis u, and its part across it."""
    dx = px - ax
    dy = py - ay
    dz = pz - az
    axial = dx * ux + dy * uy + dz * uz
    ex = dx - axial * ux
    ey = dy - axial * uy
    ez = dz - axial * uz
    return axial, ex, ey, ez, ex * ex + ey * ey + ez * ez


@kernel(inline="always")
def _cone_distance(px, py, pz, ax, ay, az, ra, bx, by, bz, rb, ux, uy, uz, length, sin_a, cos_a, axial, ex, ey, ez, radial2):
    """round_cone_distance of a capsule whose spheres do not hold each other, from its axis
    terms (see the module docstring) and p's (_axial_and_radial)."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    radial = np.sqrt(radial2)
    if radial <= TINY * length:
        ex, ey, ez = perpendicular(ux, uy, uz)
        radial = zero
    else:
        inv = one / radial
        ex *= inv
        ey *= inv
        ez *= inv
    s = axial * cos_a - radial * sin_a
    if s <= zero:
        d, nx, ny, nz = sphere_distance(px, py, pz, ax, ay, az, ra)
        return d, nx, ny, nz, zero
    if s >= length * cos_a:
        d, nx, ny, nz = sphere_distance(px, py, pz, bx, by, bz, rb)
        return d, nx, ny, nz, one
    d = axial * sin_a + radial * cos_a - ra
    nx = sin_a * ux + cos_a * ex
    ny = sin_a * uy + cos_a * ey
    nz = sin_a * uz + cos_a * ez
    # the interpolated sphere through the closest point: its centre lies along -n from it
    sigma = (axial - d * sin_a - ra * sin_a) / (length * cos_a * cos_a)
    return d, nx, ny, nz, smallest(largest(sigma, zero), one)


# Columns of a capsule record: the poses and friction, then the end pose's axis terms.
CAPSULE_COLUMNS = 24
# A point farther than this times the larger radius from the axis, or beyond either end,
# touches nothing: its distance is then at least a fifth of that radius, so the rounding of
# the arithmetic (which the full computation would do on the same terms) cannot make it a contact.
REACH = 1.25


@kernel(device=True)
def capsule_axis(C, c):
    """Fill columns 17-23 of capsule record c from its end pose (columns 8-15): the terms of
    round_cone_distance that do not depend on the point, computed as it computes them (same
    operations, same bits): unit axis u, length L, sin(alpha), cos(alpha); L is -1 when one end
    sphere holds the other (the capsule is then its bigger end sphere). Column 23 is the
    square of REACH times the larger radius."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    ax, ay, az, ra = C[c, 8], C[c, 9], C[c, 10], C[c, 11]
    bx, by, bz, rb = C[c, 12], C[c, 13], C[c, 14], C[c, 15]
    abx = bx - ax
    aby = by - ay
    abz = bz - az
    length = np.sqrt(abx * abx + aby * aby + abz * abz)
    reach = REACH * largest(ra, rb)
    C[c, 23] = reach * reach
    if length <= abs(ra - rb) or length <= TINY:
        C[c, 17] = C[c, 18] = C[c, 19] = C[c, 21] = C[c, 22] = zero
        C[c, 20] = -one
        return
    inv_length = one / length
    C[c, 17] = abx * inv_length
    C[c, 18] = aby * inv_length
    C[c, 19] = abz * inv_length
    C[c, 20] = length
    sin_a = (ra - rb) * inv_length
    C[c, 21] = sin_a
    C[c, 22] = np.sqrt(largest(one - sin_a * sin_a, zero))


@kernel(device=True)
def capsule_distance(px, py, pz, C, c):
    """round_cone_distance of p from capsule c's end pose, from the record's axis terms
    (capsule_axis), with the same bits; (inf, 0, 1, 0, 0) when p is beyond its reach (more
    than REACH times its larger radius from the axis, or beyond an end by as much)."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    ax, ay, az, ra = C[c, 8], C[c, 9], C[c, 10], C[c, 11]
    reach2 = C[c, 23]
    length = C[c, 20]
    if length < zero:  # one end sphere holds the other
        if ra >= C[c, 15]:
            d, nx, ny, nz = sphere_distance(px, py, pz, ax, ay, az, ra)
            return d, nx, ny, nz, zero
        d, nx, ny, nz = sphere_distance(px, py, pz, C[c, 12], C[c, 13], C[c, 14], C[c, 15])
        return d, nx, ny, nz, one
    ux, uy, uz = C[c, 17], C[c, 18], C[c, 19]
    axial, ex, ey, ez, radial2 = _axial_and_radial(px, py, pz, ax, ay, az, ux, uy, uz)
    beyond = axial - length  # past end b when positive
    if radial2 > reach2 or (axial < zero and axial * axial > reach2) or (beyond > zero and beyond * beyond > reach2):
        return np.inf, zero, one, zero, zero
    return _cone_distance(px, py, pz, ax, ay, az, ra, C[c, 12], C[c, 13], C[c, 14], C[c, 15], ux, uy, uz, length, C[c, 21],
                          C[c, 22], axial, ex, ey, ez, radial2)


@kernel(device=True)
def convex_distance(px, py, pz, planes, first, last, margin):
    """(distance, nx, ny, nz) of p from the convex [first, last) of ``planes`` (n, d; solid
    side n.x < d) grown by ``margin``: the largest n.p - d - margin over its planes, which is
    the exact distance inside (negative), and the plane of least penetration's normal (the
    first such plane on ties); +inf for a convex without planes."""
    if last <= first:
        return np.float32(np.inf), np.float32(0.0), np.float32(1.0), np.float32(0.0)
    best = planes[first, 0] * px + planes[first, 1] * py + planes[first, 2] * pz - planes[first, 3] - margin
    best_k = first
    for k in range(first + 1, last):
        d = planes[k, 0] * px + planes[k, 1] * py + planes[k, 2] * pz - planes[k, 3] - margin
        if d > best:
            best = d
            best_k = k
    return best, planes[best_k, 0], planes[best_k, 1], planes[best_k, 2]


@kernel(device=True)
def sphere_time_of_impact(qx, qy, qz, px, py, pz, c0x, c0y, c0z, r0, c1x, c1y, c1z, r1):
    """Earliest t in [0,1] at which the point moving q -> p touches the sphere moving
    (c0, r0) -> (c1, r1) (all linear in t), or -1 when it does not; 0 when q starts inside.

    With d(t) = (q - c0) + t e, e = (p - c1) - (q - c0), and R(t) = r0 + t dr, contact is
    |d(t)|^2 = R(t)^2: A t^2 + 2 B t + C = 0 with A = e.e - dr^2, B = d0.e - r0 dr,
    C = d0.d0 - r0^2; the earliest root is C / (-B + sqrt(B^2 - A C)).
    """
    d0x = qx - c0x
    d0y = qy - c0y
    d0z = qz - c0z
    ex = (px - c1x) - d0x
    ey = (py - c1y) - d0y
    ez = (pz - c1z) - d0z
    dr = r1 - r0
    c = d0x * d0x + d0y * d0y + d0z * d0z - r0 * r0
    if c <= np.float32(0.0):
        return np.float32(0.0)
    a = ex * ex + ey * ey + ez * ez - dr * dr
    b = d0x * ex + d0y * ey + d0z * ez - r0 * dr
    disc = b * b - a * c
    if disc < np.float32(0.0):
        return np.float32(-1.0)
    denominator = np.sqrt(disc) - b
    if denominator <= np.float32(0.0):  # moving apart: no root ahead
        return np.float32(-1.0)
    t = c / denominator
    if t > np.float32(1.0):
        return np.float32(-1.0)
    return t


@kernel(device=True)
def capsule_at(capsule_data, c, t):
    """Capsule c of ``capsule_data`` at fraction t of the iteration: (a xyz, ra, b xyz, rb)."""
    C = capsule_data
    s = np.float32(1.0) - t
    return (
        s * C[c, 0] + t * C[c, 8], s * C[c, 1] + t * C[c, 9], s * C[c, 2] + t * C[c, 10], s * C[c, 3] + t * C[c, 11],
        s * C[c, 4] + t * C[c, 12], s * C[c, 5] + t * C[c, 13], s * C[c, 6] + t * C[c, 14], s * C[c, 7] + t * C[c, 15],
    )


@kernel(device=True)
def capsule_time_of_impact(qx, qy, qz, px, py, pz, capsule_data, c):
    """(t, nx, ny, nz, sigma): earliest t in [0,1] at which the point moving q -> p touches
    capsule c moving from its start to its end pose, with the normal and sigma there; t = -1
    when it does not (then the rest is meaningless).

    Conservative advancement: the capsule is the union of the interpolated spheres, each moving
    linearly, so its signed distance from the moving point changes at most at the rate
    V = max over the two ends of |point velocity - end velocity| + max |radius rate|; stepping
    t by distance / V never steps over a contact. Stops within 1e-4 of the smaller radius, or
    after 64 steps at the last t when the point ends inside (a contact lies after it).
    """
    zero = np.float32(0.0)
    vx = px - qx
    vy = py - qy
    vz = pz - qz
    wax = vx - (capsule_data[c, 8] - capsule_data[c, 0])
    way = vy - (capsule_data[c, 9] - capsule_data[c, 1])
    waz = vz - (capsule_data[c, 10] - capsule_data[c, 2])
    wbx = vx - (capsule_data[c, 12] - capsule_data[c, 4])
    wby = vy - (capsule_data[c, 13] - capsule_data[c, 5])
    wbz = vz - (capsule_data[c, 14] - capsule_data[c, 6])
    rate = largest(np.sqrt(wax * wax + way * way + waz * waz), np.sqrt(wbx * wbx + wby * wby + wbz * wbz))
    rate += largest(abs(capsule_data[c, 11] - capsule_data[c, 3]), abs(capsule_data[c, 15] - capsule_data[c, 7]))
    ax, ay, az, ra, bx, by, bz, rb = capsule_at(capsule_data, c, zero)
    d, nx, ny, nz, sigma = round_cone_distance(qx, qy, qz, ax, ay, az, ra, bx, by, bz, rb)
    if d <= zero:
        return zero, nx, ny, nz, sigma
    if d >= rate:
        return np.float32(-1.0), nx, ny, nz, sigma
    tolerance = np.float32(1e-4) * smallest(ra, rb) + np.float32(1e-9)
    t = zero
    for _ in range(64):
        t = t + d / rate
        if t > np.float32(1.0):
            return np.float32(-1.0), nx, ny, nz, sigma
        ax, ay, az, ra, bx, by, bz, rb = capsule_at(capsule_data, c, t)
        d, nx, ny, nz, sigma = round_cone_distance(qx + t * vx, qy + t * vy, qz + t * vz, ax, ay, az, ra, bx, by, bz, rb)
        if d <= tolerance:
            return t, nx, ny, nz, sigma
    # slow convergence (a spinning capsule's tips set the rate, far above the approach speed
    # near its middle): a point that ends inside touched it after t, coming from the side of
    # the normal at t
    end, _, _, _, _ = round_cone_distance(
        px, py, pz, capsule_data[c, 8], capsule_data[c, 9], capsule_data[c, 10], capsule_data[c, 11],
        capsule_data[c, 12], capsule_data[c, 13], capsule_data[c, 14], capsule_data[c, 15],
    )
    if end <= zero:
        return t, nx, ny, nz, sigma
    return np.float32(-1.0), nx, ny, nz, sigma


@kernel(device=True)
def rotate_between(ux, uy, uz, wx, wy, wz, x, y, z):
    """Rotate (x, y, z) by the smallest rotation taking unit u to unit w (identity when u and
    w are (nearly) opposite, which a capsule does not do within one iteration)."""
    one = np.float32(1.0)
    c = ux * wx + uy * wy + uz * wz
    if c <= np.float32(-0.999):
        return x, y, z
    kx = uy * wz - uz * wy
    ky = uz * wx - ux * wz
    kz = ux * wy - uy * wx
    # Rodrigues with k = u x w (|k| = sin): x c + k x x + k (k . x) / (1 + c)
    kdot = (kx * x + ky * y + kz * z) / (one + c)
    rx = x * c + (ky * z - kz * y) + kx * kdot
    ry = y * c + (kz * x - kx * z) + ky * kdot
    rz = z * c + (kx * y - ky * x) + kz * kdot
    return rx, ry, rz
