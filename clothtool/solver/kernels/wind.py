"""Wind, drag and lift per triangle: the seed's applyWind, term for term.

For each triangle, d is the motion of its centre over the iteration relative to the air
(plus the reference frame's motion at the centre); the lift and drag impulses are

    i_lift = c_lift cos(t) sin(t) l_dir |d| / dt      l_dir = ((d x n) x d) / |d|
    i_drag = c_drag |cos(t)| d |d| / dt
    i      = (i_lift + i_drag) * rho * a               (a = twice the triangle area)

and each particle moves by -i times its inverse mass. Below |d|^2 < FLT_EPSILON the impulse
is zero (float division is unreliable there), which the seed notes makes slow cloth feel
less drag at high solver frequencies.

One guard beyond the seed: the impulse is scaled down so that it moves the triangle's centre
by at most |d|. Air can at most stop a triangle's motion relative to it; the explicit
impulse would otherwise overshoot and grow without bound on light cloth in fast air.

As in the seed, each triangle moves its particles before later triangles read them. The
triangles come in colours (``color_offsets``): the triangles of a colour share no particle, so
within a colour the order does not matter and they are solved in blocks of BLOCK, in three
passes: gather each triangle's relative motion and normal (particle rows as vectors), compute
every impulse (a loop over contiguous scratch that LLVM vectorises: the square roots and
divisions, most of a triangle's cost, eight at a time), then move the particles. The result
is bit for bit that of solving the triangles one after another in the given order.
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel
from clothtool._simd import fill, lane, load4, vadd, vmul, vsub

FLT_EPSILON = np.float32(1.1920929e-07)
BLOCK = 128
# rows of the per-block scratch, BLOCK apart: constant offsets let LLVM see they never overlap
_D0, _D1, _D2, _NX, _NY, _NZ, _W = 0, 1, 2, 3, 4, 5, 6


@kernel(inline="always")
def _gather(triangles, lo, hi, frame_matrix, frame_offset, air_offset, cur, prev, scratch):
    """Per triangle lo..hi of a colour: its centre's motion d relative to the air (with the
    frame's motion at the centre), its unnormalised normal and its particles' mean inverse mass."""
    third = np.float32(1.0 / 3.0)
    for t in range(lo, hi):
        j = t - lo
        i0 = 4 * triangles[t, 0]
        i1 = 4 * triangles[t, 1]
        i2 = 4 * triangles[t, 2]
        p0 = load4(cur, i0)
        p1 = load4(cur, i1)
        p2 = load4(cur, i2)
        centre = vmul(vadd(vadd(p0, p1), p2), fill(p0, third))
        before = vmul(vadd(vadd(load4(prev, i0), load4(prev, i1)), load4(prev, i2)), fill(p0, third))
        moved = vsub(centre, before)
        cx = lane(centre, 0)
        cy = lane(centre, 1)
        cz = lane(centre, 2)
        m = frame_matrix
        scratch[_D0 * BLOCK + j] = lane(moved, 0) + (m[0, 0] * cx + m[0, 1] * cy + m[0, 2] * cz + frame_offset[0] - air_offset[0])
        scratch[_D1 * BLOCK + j] = lane(moved, 1) + (m[1, 0] * cx + m[1, 1] * cy + m[1, 2] * cz + frame_offset[1] - air_offset[1])
        scratch[_D2 * BLOCK + j] = lane(moved, 2) + (m[2, 0] * cx + m[2, 1] * cy + m[2, 2] * cz + frame_offset[2] - air_offset[2])
        e1 = vsub(p2, p0)
        e2 = vsub(p1, p0)
        e1x, e1y, e1z = lane(e1, 0), lane(e1, 1), lane(e1, 2)
        e2x, e2y, e2z = lane(e2, 0), lane(e2, 1), lane(e2, 2)
        scratch[_NX * BLOCK + j] = e1y * e2z - e1z * e2y
        scratch[_NY * BLOCK + j] = e1z * e2x - e1x * e2z
        scratch[_NZ * BLOCK + j] = e1x * e2y - e1y * e2x
        scratch[_W * BLOCK + j] = (lane(p0, 3) + lane(p1, 3) + lane(p2, 3)) * third


@kernel(inline="always")
def _impulses(count, inv_dt, drag, lift, density, scratch, impulse):
    """impulse[k * BLOCK + j] = component k of triangle j's impulse (0 below the epsilon or
    for a degenerate triangle), from the gathered scratch."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    for j in range(count):
        d0 = scratch[_D0 * BLOCK + j]
        d1 = scratch[_D1 * BLOCK + j]
        d2 = scratch[_D2 * BLOCK + j]
        nx = scratch[_NX * BLOCK + j]
        ny = scratch[_NY * BLOCK + j]
        nz = scratch[_NZ * BLOCK + j]
        double_area = np.sqrt(nx * nx + ny * ny + nz * nz)
        length_sqr = d0 * d0 + d1 * d1 + d2 * d2
        skip = (length_sqr < FLT_EPSILON) | (double_area == zero)
        nx /= double_area
        ny /= double_area
        nz /= double_area
        length = np.sqrt(length_sqr)
        cos_theta = (nx * d0 + ny * d1 + nz * d2) / length
        sin_theta = np.sqrt(max(zero, one - cos_theta * cos_theta))
        # (d x n) x d / |d|
        ax = d1 * nz - d2 * ny
        ay = d2 * nx - d0 * nz
        az = d0 * ny - d1 * nx
        lx = (ay * d2 - az * d1) / length
        ly = (az * d0 - ax * d2) / length
        lz = (ax * d1 - ay * d0) / length
        lift_scale = lift * cos_theta * sin_theta * length * inv_dt
        drag_scale = drag * abs(cos_theta) * length * inv_dt
        scale = density * double_area
        ix = (lift_scale * lx + drag_scale * d0) * scale
        iy = (lift_scale * ly + drag_scale * d1) * scale
        iz = (lift_scale * lz + drag_scale * d2) * scale
        shift = np.sqrt(ix * ix + iy * iy + iz * iz) * scratch[_W * BLOCK + j]
        limit = length / shift if shift > length else one
        impulse[j] = zero if skip else ix * limit
        impulse[BLOCK + j] = zero if skip else iy * limit
        impulse[2 * BLOCK + j] = zero if skip else iz * limit


@kernel
def apply_wind(triangles, color_offsets, frame_matrix, frame_offset, air_offset, inv_dt, drag, lift, density, cur, prev):
    """triangles (t,3), in colours: triangles[color_offsets[k]:color_offsets[k+1]] share no
    particle; frame_matrix (3,3), frame_offset (3,): the frame's motion over the iteration at
    a point x is frame_matrix @ x + frame_offset; air_offset (3,): wind velocity * dt in local
    space; drag, lift: per-iteration coefficients; density: fluid density (NvCloth's,
    compensating for the doubled area)."""
    flat = cur.reshape(-1)
    flat_prev = prev.reshape(-1)
    scratch = np.empty(7 * BLOCK, cur.dtype)
    impulse = np.empty(3 * BLOCK, cur.dtype)
    for color in range(color_offsets.shape[0] - 1):
        first = color_offsets[color]
        size = color_offsets[color + 1] - first
        for block in range((size + BLOCK - 1) // BLOCK):
            # unsigned indices: no negative-index wraparound code, which blocks vectorisation
            lo = np.uintp(first + block * BLOCK)
            hi = np.uintp(first + min(block * BLOCK + BLOCK, size))
            _gather(triangles, lo, hi, frame_matrix, frame_offset, air_offset, flat, flat_prev, scratch)
            _impulses(hi - lo, inv_dt, drag, lift, density, scratch, impulse)
            for t in range(lo, hi):
                j = t - lo
                for corner in range(3):
                    i = 4 * triangles[t, corner]
                    w = flat[i + 3]
                    flat[i] -= impulse[j] * w
                    flat[i + 1] -= impulse[BLOCK + j] * w
                    flat[i + 2] -= impulse[2 * BLOCK + j] * w
