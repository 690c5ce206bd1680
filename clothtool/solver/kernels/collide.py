"""Collision of particles and virtual particles with the colliders (NvCloth's collideParticles).

The kernels read packed records (see collide_shapes, collide_mesh), all in the cloth's local
frame and posed for the current iteration by the stage (clothtool.solver.kernels.collide_pose):

    shapes = (sphere_data (s,9), capsule_data (c,24), planes at the end (p,4),
              convex offsets i32 (k+1,), convex_data (k,5): margin, friction, own shift xyz)
    mesh   = (triangle_data (t,32), cell_start i32, cell_items i32, cell_ranges i32 (t,6),
              grid (7,))
    frame  = (8,3) float64: the cloth frame's poses at the iteration's start and end

Per particle (one that can move: prev.w > 0 and cur.w > 0):

1. continuous collision (optional) with spheres and capsules: the earliest time of impact of
   the particle's path prev -> cur against each moving collider; when the particle would end
   on the far side of it (the outward normal where it stops points against the normal where
   it hit), it is put on the end pose's surface where it hit (NvCloth: it sticks to the
   collider for the rest of the iteration).
2. discrete contacts at cur, each a push-out to the margin: one per sphere, capsule and convex
   it is inside, plus the deepest mesh triangle; the particle moves by their AVERAGE.
3. friction: with n the direction of that average push-out, the particle's displacement over
   the iteration relative to the colliders' surfaces (cur - prev - average surface
   displacement at the contacts) loses min(1, budget / |tangential part|) of its tangential
   part, where budget is the average of mu * |push-out| over the contacts (Coulomb's law for
   positions: the normal correction bounds the tangential one).
4. collision mass scale (NvCloth): cur.w *= 1 / (1 + mass_scale * |push-out in metres|^2);
   integration restores it from prev.w next iteration.

Arrays are unpacked once per kernel and handed to device functions only when they hold
primitives: every array passed to a call costs reference counting, per particle.
"""

from __future__ import annotations

import functools

import numba
import numpy as np

from clothtool._jit import kernel, serial_and_parallel
from clothtool._minmax import smallest
from clothtool.solver.kernels.collide_mesh import mesh_contact
from clothtool.solver.kernels.collide_shapes import (
    REACH,
    capsule_at,
    capsule_distance,
    capsule_time_of_impact,
    convex_distance,
    rotate_between,
    round_cone_distance,
    sphere_distance,
    sphere_time_of_impact,
)

TINY = np.float32(1e-12)


@kernel(device=True)
def _unit(x, y, z):
    """(x, y, z) / |(x, y, z)|, or +y for a zero vector."""
    length = np.sqrt(x * x + y * y + z * z)
    if length <= TINY:
        return np.float32(0.0), np.float32(1.0), np.float32(0.0)
    inv = np.float32(1.0) / length
    return x * inv, y * inv, z * inv


@kernel(inline="always")
def continuous_contact(px, py, pz, qx, qy, qz, sphere_data, capsule_data):
    """(moved, x, y, z): where the particle moving q -> p ends after continuous collision:
    p itself, or the end pose's surface point where it hit the collider with the earliest
    time of impact among those it would otherwise end up beyond."""
    one = np.float32(1.0)
    best = np.float32(2.0)
    rx, ry, rz = px, py, pz
    S = sphere_data
    for s in range(S.shape[0]):
        t = sphere_time_of_impact(
            qx, qy, qz, px, py, pz, S[s, 0], S[s, 1], S[s, 2], S[s, 3], S[s, 4], S[s, 5], S[s, 6], S[s, 7]
        )
        if t < 0.0 or t >= best:
            continue
        u = one - t
        hx, hy, hz = _unit(
            u * qx + t * px - (u * S[s, 0] + t * S[s, 4]),
            u * qy + t * py - (u * S[s, 1] + t * S[s, 5]),
            u * qz + t * pz - (u * S[s, 2] + t * S[s, 6]),
        )
        _, nx, ny, nz = sphere_distance(px, py, pz, S[s, 4], S[s, 5], S[s, 6], S[s, 7])
        if nx * hx + ny * hy + nz * hz >= 0.0:
            continue  # ends on the side it came from: discrete collision will do
        best = t
        rx = S[s, 4] + S[s, 7] * hx
        ry = S[s, 5] + S[s, 7] * hy
        rz = S[s, 6] + S[s, 7] * hz
    C = capsule_data
    for c in range(C.shape[0]):
        t, hx, hy, hz, sigma = capsule_time_of_impact(qx, qy, qz, px, py, pz, C, c)
        if t < 0.0 or t >= best:
            continue
        _, nx, ny, nz, _ = round_cone_distance(
            px, py, pz, C[c, 8], C[c, 9], C[c, 10], C[c, 11], C[c, 12], C[c, 13], C[c, 14], C[c, 15]
        )
        if nx * hx + ny * hy + nz * hz >= 0.0:
            continue
        # carry the hit normal with the capsule's axis from time t to the end
        ax, ay, az, _, bx, by, bz, _ = capsule_at(C, c, t)
        ux, uy, uz = _unit(bx - ax, by - ay, bz - az)
        ex, ey, ez = _unit(C[c, 12] - C[c, 8], C[c, 13] - C[c, 9], C[c, 14] - C[c, 10])
        hx, hy, hz = rotate_between(ux, uy, uz, ex, ey, ez, hx, hy, hz)
        w = one - sigma
        radius = w * C[c, 11] + sigma * C[c, 15]
        best = t
        rx = w * C[c, 8] + sigma * C[c, 12] + radius * hx
        ry = w * C[c, 9] + sigma * C[c, 13] + radius * hy
        rz = w * C[c, 10] + sigma * C[c, 14] + radius * hz
    return best <= one, rx, ry, rz


@kernel(inline="always")
def sphere_contacts(px, py, pz, sphere_data):
    """Contacts of the point p with the spheres: (count, push-out sum xyz, surface
    displacement sum xyz, sum of friction * |push-out|)."""
    zero = np.float32(0.0)
    count = 0
    dx = dy = dz = sx = sy = sz = budget = zero
    S = sphere_data
    for s in range(S.shape[0]):
        # beyond 1.25 radii the distance is at least a quarter radius: skip the square root
        ox = px - S[s, 4]
        oy = py - S[s, 5]
        oz = pz - S[s, 6]
        reach = REACH * S[s, 7]
        if ox * ox + oy * oy + oz * oz > reach * reach:
            continue
        d, nx, ny, nz = sphere_distance(px, py, pz, S[s, 4], S[s, 5], S[s, 6], S[s, 7])
        if d < zero:
            count += 1
            dx -= d * nx
            dy -= d * ny
            dz -= d * nz
            sx += S[s, 4] - S[s, 0]
            sy += S[s, 5] - S[s, 1]
            sz += S[s, 6] - S[s, 2]
            budget -= S[s, 8] * d
    return count, dx, dy, dz, sx, sy, sz, budget


@kernel(inline="always")
def capsule_contacts(px, py, pz, capsule_data):
    """Contacts of the point p with the capsules, as sphere_contacts; the surface displacement
    is the end spheres' displacements interpolated at the contact's sigma."""
    zero = np.float32(0.0)
    count = 0
    dx = dy = dz = sx = sy = sz = budget = zero
    C = capsule_data
    for c in range(C.shape[0]):
        d, nx, ny, nz, sigma = capsule_distance(px, py, pz, C, c)
        if d < zero:
            count += 1
            dx -= d * nx
            dy -= d * ny
            dz -= d * nz
            w = np.float32(1.0) - sigma
            sx += w * (C[c, 8] - C[c, 0]) + sigma * (C[c, 12] - C[c, 4])
            sy += w * (C[c, 9] - C[c, 1]) + sigma * (C[c, 13] - C[c, 5])
            sz += w * (C[c, 10] - C[c, 2]) + sigma * (C[c, 14] - C[c, 6])
            budget -= C[c, 16] * d
    return count, dx, dy, dz, sx, sy, sz, budget


@kernel(device=True)
def frame_motion(frame, x, y, z):
    """Displacement over the iteration, in local coordinates, of the world-fixed point that
    sits at local x at the iteration's end: x - R0^T (R1 x + T1 - T0)."""
    wx = frame[4, 0] * x + frame[4, 1] * y + frame[4, 2] * z + frame[7, 0] - frame[3, 0]
    wy = frame[5, 0] * x + frame[5, 1] * y + frame[5, 2] * z + frame[7, 1] - frame[3, 1]
    wz = frame[6, 0] * x + frame[6, 1] * y + frame[6, 2] * z + frame[7, 2] - frame[3, 2]
    lx = frame[0, 0] * wx + frame[1, 0] * wy + frame[2, 0] * wz
    ly = frame[0, 1] * wx + frame[1, 1] * wy + frame[2, 1] * wz
    lz = frame[0, 2] * wx + frame[1, 2] * wy + frame[2, 2] * wz
    return np.float32(x - lx), np.float32(y - ly), np.float32(z - lz)


@kernel(inline="always")
def convex_contacts(px, py, pz, planes, offsets, convex_data, frame):
    """Contacts of the point p with the convexes, as sphere_contacts; the surface point moves
    with the world (frame_motion) plus the convex's own shift."""
    zero = np.float32(0.0)
    count = 0
    dx = dy = dz = sx = sy = sz = budget = zero
    for k in range(offsets.shape[0] - 1):
        d, nx, ny, nz = convex_distance(px, py, pz, planes, offsets[k], offsets[k + 1], convex_data[k, 0])
        if d < zero:
            count += 1
            dx -= d * nx
            dy -= d * ny
            dz -= d * nz
            mx, my, mz = frame_motion(frame, px - d * nx, py - d * ny, pz - d * nz)
            sx += mx + convex_data[k, 2]
            sy += my + convex_data[k, 3]
            sz += mz + convex_data[k, 4]
            budget -= convex_data[k, 1] * d
    return count, dx, dy, dz, sx, sy, sz, budget


@kernel(device=True)
def friction_correction(px, py, pz, qx, qy, qz, dx, dy, dz, sx, sy, sz, budget):
    """Correction to add to p (already pushed out by d) that removes min(1, budget / |t|) of
    t, the part of the relative displacement p - q - s tangential to d."""
    zero = np.float32(0.0)
    rx = px - qx - sx
    ry = py - qy - sy
    rz = pz - qz - sz
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    if length > TINY:
        inv = np.float32(1.0) / length
        nx = dx * inv
        ny = dy * inv
        nz = dz * inv
        normal = rx * nx + ry * ny + rz * nz
        rx -= normal * nx
        ry -= normal * ny
        rz -= normal * nz
    tangential = np.sqrt(rx * rx + ry * ry + rz * rz)
    if tangential <= TINY or budget <= zero:
        return zero, zero, zero
    fraction = smallest(np.float32(1.0), budget / tangential)
    return -fraction * rx, -fraction * ry, -fraction * rz


# The kernels below sum each primitive kind's contacts at the call site, from arrays bound
# before their particle loop. A helper taking the arrays (even inlined) would reference-count
# each of them per particle: 22 atomic operations per particle, twice the cost of a sphere.
@kernel(inline="always")
def _add_contacts(total, part):
    """Sum of two contact summaries (count, push-out xyz, surface motion xyz, friction budget)."""
    return (
        total[0] + part[0], total[1] + part[1], total[2] + part[2], total[3] + part[3],
        total[4] + part[4], total[5] + part[5], total[6] + part[6], total[7] + part[7],
    )


@kernel(inline="always")
def _mesh_summary(found):
    """The deepest mesh contact (mesh_contact's result) as a contact summary."""
    hit, ex, ey, ez, tx, ty, tz, mu = found
    if not hit:
        zero = np.float32(0.0)
        return 0, zero, zero, zero, zero, zero, zero, zero
    return 1, ex, ey, ez, tx, ty, tz, mu * np.sqrt(ex * ex + ey * ey + ez * ez)


def _make_point_correction(with_meshes: bool, with_convexes: bool, with_continuous: bool):
    """``point_correction`` with the code of mesh colliders, convex colliders and continuous
    collision each kept or left out (closure constants, pruned before typing, as in
    ``_make_collide_particles``): the virtual particles of a scene of spheres and capsules
    compile a small kernel instead of the general one (most of a cold start's compile time)."""

    def point_correction(px, py, pz, qx, qy, qz, shapes, mesh, frame, continuous):
        """The collision geometry of one point moving q -> p over the iteration, for integrators
        that make their own response (implicit, explicit): (count, mx, my, mz, dx, dy, dz, sx,
        sy, sz, budget). m is the continuous move (to where it hit a sphere or capsule on the side
        it came from; zero when ``continuous`` is off or it hit nothing), then d, s and budget
        are the AVERAGE push-out, surface displacement and friction budget (mu * |push-out|) of
        the ``count`` discrete contacts at p + m: steps 1-2 of the module docstring, as the
        position-based particle kernel computes them."""
        zero = np.float32(0.0)
        sphere_data, capsule_data, planes, offsets, convex_data = shapes
        triangle_data, cell_start, cell_items, cell_ranges, grid = mesh
        mx = my = mz = zero
        if with_continuous:  # closure constants: numba prunes these branches before typing
            if continuous and (sphere_data.shape[0] > 0 or capsule_data.shape[0] > 0):
                _, rx, ry, rz = continuous_contact(px, py, pz, qx, qy, qz, sphere_data, capsule_data)
                mx = rx - px
                my = ry - py
                mz = rz - pz
                px = rx
                py = ry
                pz = rz
        total = (0, zero, zero, zero, zero, zero, zero, zero)
        if sphere_data.shape[0] > 0:
            total = _add_contacts(total, sphere_contacts(px, py, pz, sphere_data))
        if capsule_data.shape[0] > 0:
            total = _add_contacts(total, capsule_contacts(px, py, pz, capsule_data))
        if with_convexes:
            if offsets.shape[0] > 1:
                total = _add_contacts(total, convex_contacts(px, py, pz, planes, offsets, convex_data, frame))
        if with_meshes:
            if triangle_data.shape[0] > 0:
                found = mesh_contact(px, py, pz, qx, qy, qz, triangle_data, cell_start, cell_items, cell_ranges, grid, frame)
                total = _add_contacts(total, _mesh_summary(found))
        count, dx, dy, dz, sx, sy, sz, budget = total
        if count > 0:
            inv = np.float32(1.0) / np.float32(count)
            dx *= inv
            dy *= inv
            dz *= inv
            sx *= inv
            sy *= inv
            sz *= inv
            budget *= inv
        return count, mx, my, mz, dx, dy, dz, sx, sy, sz, budget

    return kernel(inline="always")(point_correction)


# The variants collide_virtual picks from (compiled only when used; see _make_collide_virtual).
# The general one serves the implicit and explicit integrators' responses.
_spheres_only = _make_point_correction(False, False, False)
_spheres_continuous = _make_point_correction(False, False, True)
_with_convexes = _make_point_correction(False, True, False)
_with_convexes_continuous = _make_point_correction(False, True, True)
_with_meshes = _make_point_correction(True, False, False)
_with_meshes_continuous = _make_point_correction(True, False, True)
_with_both = _make_point_correction(True, True, False)
point_correction = _make_point_correction(True, True, True)


def _make_collide_particles(with_meshes: bool, with_convexes: bool, with_continuous: bool):
    """The particle kernel's source with the code of mesh colliders, convex colliders
    (planes included) and continuous collision each kept or left out: the flags are closure
    constants, so numba prunes the branches they guard before typing them and a scene pays
    compile time only for the kinds it has. With all three kept it is the general kernel."""

    def _collide_particles(shapes, mesh, frame, prev, continuous, mass_scale, meters_per_unit, cur):
        """Collide every movable particle (see the module docstring); writes only its own row."""
        zero = np.float32(0.0)
        one = np.float32(1.0)
        sphere_data, capsule_data, planes, offsets, convex_data = shapes
        triangle_data, cell_start, cell_items, cell_ranges, grid = mesh
        spheres = sphere_data.shape[0] > 0
        capsules = capsule_data.shape[0] > 0
        convexes = offsets.shape[0] > 1
        meshes = triangle_data.shape[0] > 0
        continuous = continuous and (spheres or capsules)
        for p in numba.prange(cur.shape[0]):
            if prev[p, 3] == 0.0 or cur[p, 3] == 0.0:
                continue
            px = cur[p, 0]
            py = cur[p, 1]
            pz = cur[p, 2]
            qx = prev[p, 0]
            qy = prev[p, 1]
            qz = prev[p, 2]
            if with_continuous:  # a closure constant: numba prunes the branch before typing it
                if continuous:
                    _, px, py, pz = continuous_contact(px, py, pz, qx, qy, qz, sphere_data, capsule_data)
            total = (0, zero, zero, zero, zero, zero, zero, zero)
            if spheres:
                total = _add_contacts(total, sphere_contacts(px, py, pz, sphere_data))
            if capsules:
                total = _add_contacts(total, capsule_contacts(px, py, pz, capsule_data))
            if with_convexes:
                if convexes:
                    total = _add_contacts(total, convex_contacts(px, py, pz, planes, offsets, convex_data, frame))
            if with_meshes:
                if meshes:
                    found = mesh_contact(
                        px, py, pz, qx, qy, qz, triangle_data, cell_start, cell_items, cell_ranges, grid, frame
                    )
                    total = _add_contacts(total, _mesh_summary(found))
            count, dx, dy, dz, sx, sy, sz, budget = total
            if count > 0:
                inv = one / np.float32(count)
                dx *= inv
                dy *= inv
                dz *= inv
                px += dx
                py += dy
                pz += dz
                fx, fy, fz = friction_correction(px, py, pz, qx, qy, qz, dx, dy, dz, sx * inv, sy * inv, sz * inv, budget * inv)
                px += fx
                py += fy
                pz += fz
                if mass_scale > 0.0:
                    square = (dx * dx + dy * dy + dz * dz) * meters_per_unit * meters_per_unit
                    cur[p, 3] *= one / (one + mass_scale * square)
            cur[p, 0] = px
            cur[p, 1] = py
            cur[p, 2] = pz

    return _collide_particles


@functools.lru_cache(maxsize=None)
def collide_particles_for(meshes: bool, convexes: bool, continuous: bool):
    """(serial, parallel) particle kernels that handle mesh colliders, convex colliders and
    continuous collision only when asked (the ones left out must be absent or off in the
    arguments); same arguments and results as ``collide_particles``."""
    kernels = serial_and_parallel(_make_collide_particles(meshes, convexes, continuous))
    for index, dispatcher in enumerate(kernels):  # how a generated frame function gets it
        dispatcher.frame_import = f"collide_particles_for({meshes}, {convexes}, {continuous})[{index}]"
    return kernels


collide_particles, collide_particles_parallel = collide_particles_for(True, True, True)


@kernel(inline="always")
def weighted_point(state, a, b, c, wa, wb, wc):
    """wa state[a] + wb state[b] + wc state[c] (xyz): a point of triangle abc."""
    return (
        wa * state[a, 0] + wb * state[b, 0] + wc * state[c, 0],
        wa * state[a, 1] + wb * state[b, 1] + wc * state[c, 1],
        wa * state[a, 2] + wb * state[b, 2] + wc * state[c, 2],
    )


@kernel(inline="always")
def movable_weights(cur, prev, a, b, c, wa, wb, wc):
    """(ma, mb, mc, sum of their squares): a triangle point's weights kept for the corners
    that move (0 for one pinned at the iteration's start or end). A correction c of the point
    moves corner i by c m_i / sum(m^2), so the point itself moves by c."""
    zero = np.float32(0.0)
    ma = wa if prev[a, 3] > zero and cur[a, 3] > zero else zero
    mb = wb if prev[b, 3] > zero and cur[b, 3] > zero else zero
    mc = wc if prev[c, 3] > zero and cur[c, 3] > zero else zero
    return ma, mb, mc, ma * ma + mb * mb + mc * mc


@kernel(inline="always")
def share_out(cur, a, b, c, ma, mb, mc, norm, cx, cy, cz, scale, cap):
    """Move a triangle point by its correction c through the corners that move (their kept
    weights m, ``movable_weights``): corner i by c min(m_i / sum(m^2), cap), its inverse mass
    scaled by 1 + (scale - 1) m_i (the collision mass scale, NvCloth)."""
    one = np.float32(1.0)
    for particle, m in ((a, ma), (b, mb), (c, mc)):
        if m == np.float32(0.0):
            continue
        share = smallest(m / norm, cap)
        cur[particle, 0] += cx * share
        cur[particle, 1] += cy * share
        cur[particle, 2] += cz * share
        cur[particle, 3] *= one + (scale - one) * m


def _make_collide_virtual(with_meshes: bool, with_convexes: bool, with_continuous: bool):
    """``collide_virtual`` over the ``point_correction`` kept to the collider kinds present.
    It picks its variant by closure constants among the module's globals, not by capturing
    the function: numba keys a closure's cache entry by its captured values, and a captured
    function pickles differently in every process (the kernel would recompile every run)."""

    def collide_virtual(virtual, weights, shapes, mesh, frame, prev, continuous, mass_scale, meters_per_unit, cur):
        """Virtual particles (rows i, j, k, weight row): the weighted point of three particles
        collides like a particle (``point_correction``: continuous collision when ``continuous``,
        discrete contacts; friction, mass scale) and its correction c is shared out as
        x += c * w / sum(w^2) over the movable ones, so the point itself moves by c;
        a particle's inverse mass is scaled by 1 + (scale - 1) w (NvCloth). Rows are processed in
        order, each seeing the corrections before it; the fabric orders them in conflict-free
        batches, so this equals solving each batch at once."""
        zero = np.float32(0.0)
        one = np.float32(1.0)
        for r in range(virtual.shape[0]):
            a = virtual[r, 0]
            b = virtual[r, 1]
            c = virtual[r, 2]
            wa = weights[virtual[r, 3], 0]
            wb = weights[virtual[r, 3], 1]
            wc = weights[virtual[r, 3], 2]
            ma, mb, mc, norm = movable_weights(cur, prev, a, b, c, wa, wb, wc)
            if norm <= zero:
                continue
            px, py, pz = weighted_point(cur, a, b, c, wa, wb, wc)
            # the point at the iteration's start: for continuous collision and meshes, else
            # (the variants without them never read it) only for the friction of a contact
            qx = qy = qz = zero
            if with_continuous or with_meshes:
                qx, qy, qz = weighted_point(prev, a, b, c, wa, wb, wc)
            # the point's own continuous move (to where it hit, on the side it came from) is part
            # of its correction, shared out like the push-out. The variant for the collider kinds
            # present: closure constants, so numba prunes the branches not taken before typing
            if with_meshes:
                if with_convexes:
                    if with_continuous:
                        result = point_correction(px, py, pz, qx, qy, qz, shapes, mesh, frame, continuous)
                    else:
                        result = _with_both(px, py, pz, qx, qy, qz, shapes, mesh, frame, continuous)
                elif with_continuous:
                    result = _with_meshes_continuous(px, py, pz, qx, qy, qz, shapes, mesh, frame, continuous)
                else:
                    result = _with_meshes(px, py, pz, qx, qy, qz, shapes, mesh, frame, continuous)
            elif with_convexes:
                if with_continuous:
                    result = _with_convexes_continuous(px, py, pz, qx, qy, qz, shapes, mesh, frame, continuous)
                else:
                    result = _with_convexes(px, py, pz, qx, qy, qz, shapes, mesh, frame, continuous)
            elif with_continuous:
                result = _spheres_continuous(px, py, pz, qx, qy, qz, shapes, mesh, frame, continuous)
            else:
                result = _spheres_only(px, py, pz, qx, qy, qz, shapes, mesh, frame, continuous)
            count, mx, my, mz, dx, dy, dz, sx, sy, sz, budget = result
            if count == 0 and mx == zero and my == zero and mz == zero:
                continue
            cx = mx
            cy = my
            cz = mz
            scale = one
            if count > 0:
                if not (with_continuous or with_meshes):
                    qx, qy, qz = weighted_point(prev, a, b, c, wa, wb, wc)
                fx, fy, fz = friction_correction(
                    px + mx + dx, py + my + dy, pz + mz + dz, qx, qy, qz, dx, dy, dz, sx, sy, sz, budget
                )
                cx += dx + fx
                cy += dy + fy
                cz += dz + fz
            if count > 0 and mass_scale > 0.0:
                square = (dx * dx + dy * dy + dz * dz) * meters_per_unit * meters_per_unit
                scale = one / (one + mass_scale * square)
            share_out(cur, a, b, c, ma, mb, mc, norm, cx, cy, cz, scale, np.float32(np.inf))  # the point moves by c

    return collide_virtual


@functools.lru_cache(maxsize=None)
def collide_virtual_for(meshes: bool, convexes: bool, continuous: bool):
    """The virtual-particle kernel that handles mesh colliders, convex colliders and
    continuous collision only when asked (same arguments and results as ``collide_virtual``)."""
    dispatcher = kernel(_make_collide_virtual(meshes, convexes, continuous))
    dispatcher.frame_import = f"collide_virtual_for({meshes}, {convexes}, {continuous})"  # for frame functions
    return dispatcher


collide_virtual = collide_virtual_for(True, True, True)
