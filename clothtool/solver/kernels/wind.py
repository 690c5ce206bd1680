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
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel

FLT_EPSILON = np.float32(1.1920929e-07)


@kernel
def apply_wind(triangles, frame_matrix, frame_offset, air_offset, inv_dt, drag, lift, density, cur, prev):
    """triangles (t,3); frame_matrix (3,3), frame_offset (3,): the frame's motion over the
    iteration at a point x is frame_matrix @ x + frame_offset; air_offset (3,): wind
    velocity * dt in local space; drag, lift: per-iteration coefficients; density: fluid
    density (NvCloth's, compensating for the doubled area)."""
    third = np.float32(1.0 / 3.0)
    zero = np.float32(0.0)
    one = np.float32(1.0)
    for t in range(triangles.shape[0]):
        i0 = triangles[t, 0]
        i1 = triangles[t, 1]
        i2 = triangles[t, 2]
        cx = (cur[i0, 0] + cur[i1, 0] + cur[i2, 0]) * third
        cy = (cur[i0, 1] + cur[i1, 1] + cur[i2, 1]) * third
        cz = (cur[i0, 2] + cur[i1, 2] + cur[i2, 2]) * third
        d0 = cx - (prev[i0, 0] + prev[i1, 0] + prev[i2, 0]) * third
        d1 = cy - (prev[i0, 1] + prev[i1, 1] + prev[i2, 1]) * third
        d2 = cz - (prev[i0, 2] + prev[i1, 2] + prev[i2, 2]) * third
        d0 += frame_matrix[0, 0] * cx + frame_matrix[0, 1] * cy + frame_matrix[0, 2] * cz + frame_offset[0] - air_offset[0]
        d1 += frame_matrix[1, 0] * cx + frame_matrix[1, 1] * cy + frame_matrix[1, 2] * cz + frame_offset[1] - air_offset[1]
        d2 += frame_matrix[2, 0] * cx + frame_matrix[2, 1] * cy + frame_matrix[2, 2] * cz + frame_offset[2] - air_offset[2]

        e1x = cur[i2, 0] - cur[i0, 0]
        e1y = cur[i2, 1] - cur[i0, 1]
        e1z = cur[i2, 2] - cur[i0, 2]
        e2x = cur[i1, 0] - cur[i0, 0]
        e2y = cur[i1, 1] - cur[i0, 1]
        e2z = cur[i1, 2] - cur[i0, 2]
        nx = e1y * e2z - e1z * e2y
        ny = e1z * e2x - e1x * e2z
        nz = e1x * e2y - e1y * e2x
        double_area = np.sqrt(nx * nx + ny * ny + nz * nz)
        length_sqr = d0 * d0 + d1 * d1 + d2 * d2
        if length_sqr < FLT_EPSILON or double_area == zero:
            continue
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
        shift = np.sqrt(ix * ix + iy * iy + iz * iz) * (cur[i0, 3] + cur[i1, 3] + cur[i2, 3]) * third
        if shift > length:
            limit = length / shift
            ix *= limit
            iy *= limit
            iz *= limit
        for i in (i0, i1, i2):
            w = cur[i, 3]
            cur[i, 0] -= ix * w
            cur[i, 1] -= iy * w
            cur[i, 2] -= iz * w
