"""Wind, drag and lift per triangle: the seed's applyWind with the physical air law.

For each triangle, d is the motion of its centre over the iteration relative to the air
(plus the reference frame's motion at the centre), m = (c2 - c0) x (c1 - c0) its unnormalised
normal, and each corner i moves by

    -w_i * share_i * density * G(d, m)   G of clothtool.solver.kernels.air, density = rho s^3 / 12

which is F h^2 w_i / 3 (times the particle's share, clothtool.solver.air: 1 on a triangle
mesh) for the triangle's force F = -1/2 rho A (C_d |cos| |v| v + lift) at the
velocity v = d / h (in metres: s^3 because G has d twice and m once): each corner takes a
third of its triangle's force (air.py says why a third), so the step length cancels and
nothing depends on the solver frequency. (The seed moves every corner by the whole
triangle's impulse, three times the force, and skips triangles with |d|^2 < FLT_EPSILON,
which is every triangle slower than 1.33 m/s at 3840 Hz; neither is kept.) Only a triangle
without area or relative motion gets no push.

One guard beyond the seed: the push is scaled down so that it moves the triangle's centre
by at most |d|. Air can at most stop a triangle's motion relative to it; the explicit
push would otherwise overshoot and grow without bound on light cloth in fast air. It never
acts near the terminal speed (the push per iteration is then g h^2, |d| is v h, and g h is
far below any terminal speed), so it does not bias the drag law.

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
from clothtool._minmax import smallest
from clothtool._simd import fill, lane, load4, vadd, vmul, vsub
from clothtool.solver.kernels.air import triangle_air

BLOCK = 128
# rows of the per-block scratch, BLOCK apart: constant offsets let LLVM see they never overlap
_D0, _D1, _D2, _NX, _NY, _NZ, _W = 0, 1, 2, 3, 4, 5, 6


@kernel(inline="always")
def _gather(triangles, share, lo, hi, frame_matrix, frame_offset, air_offset, cur, prev, scratch):
    """Per triangle lo..hi of a colour: its centre's motion d relative to the air (with the
    frame's motion at the centre), its unnormalised normal and the mean over its corners of
    inverse mass times share."""
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
        w0 = lane(p0, 3) * share[triangles[t, 0]]
        w1 = lane(p1, 3) * share[triangles[t, 1]]
        w2 = lane(p2, 3) * share[triangles[t, 2]]
        scratch[_W * BLOCK + j] = (w0 + w1 + w2) * third


@kernel(inline="always")
def _impulses(count, drag, lift, density, scratch, impulse):
    """impulse[k * BLOCK + j] = component k of triangle j's push per unit inverse mass (0
    without motion or area), from the gathered scratch."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    for j in range(count):
        d0 = scratch[_D0 * BLOCK + j]
        d1 = scratch[_D1 * BLOCK + j]
        d2 = scratch[_D2 * BLOCK + j]
        gx, gy, gz, ok = triangle_air(d0, d1, d2, scratch[_NX * BLOCK + j], scratch[_NY * BLOCK + j],
                                      scratch[_NZ * BLOCK + j], drag, lift)
        ix = gx * density
        iy = gy * density
        iz = gz * density
        length = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        shift = np.sqrt(ix * ix + iy * iy + iz * iz) * scratch[_W * BLOCK + j]
        limit = length / shift if shift > length else one
        impulse[j] = ix * limit if ok else zero
        impulse[BLOCK + j] = iy * limit if ok else zero
        impulse[2 * BLOCK + j] = iz * limit if ok else zero


@kernel
def apply_wind(triangles, color_offsets, share, frame_matrix, frame_offset, air_offset, drag, lift, density, cur, prev):
    """triangles (t,3), in colours: triangles[color_offsets[k]:color_offsets[k+1]] share no
    particle; share (n,): each particle's share in its triangles' force
    (``clothtool.solver.air``, 1 for a triangle mesh); frame_matrix (3,3), frame_offset (3,): the frame's motion over the iteration at
    a point x is frame_matrix @ x + frame_offset; air_offset (3,): wind velocity * dt in local
    space; drag, lift: the aerodynamic coefficients C_d, C_l; density: rho s^3 / 12 (air
    density rho in kg/m^3, s metres per scene unit; the module docstring says why)."""
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
            hi = np.uintp(first + smallest(block * BLOCK + BLOCK, size))
            _gather(triangles, share, lo, hi, frame_matrix, frame_offset, air_offset, flat, flat_prev, scratch)
            _impulses(hi - lo, drag, lift, density, scratch, impulse)
            for t in range(lo, hi):
                j = t - lo
                for corner in range(3):
                    k = triangles[t, corner]
                    i = 4 * k
                    w = flat[i + 3] * share[k]
                    flat[i] -= impulse[j] * w
                    flat[i + 1] -= impulse[BLOCK + j] * w
                    flat[i + 2] -= impulse[2 * BLOCK + j] * w
