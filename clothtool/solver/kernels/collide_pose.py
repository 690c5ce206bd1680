"""Collider poses within a frame, and the packed records the collide kernels read.

Colliders are interpolated linearly between the frame's start and end (NvCloth's
start/target scheme), then taken from world space into the cloth's frame. ``frame`` (8,3)
float64 holds the frame's pose at the iteration's start (R0 rows 0-2, T0 row 3) and end (R1
rows 4-6, T1 row 7), local x -> world R x + T; ``end`` picks one (0 or 1). A world point goes
to R^T (x - T), a world plane n . x = d to (R^T n) . x = d - n . T. Interpolated plane
normals are renormalised, with the offset divided by the same length.
"""

from __future__ import annotations

import numpy as np

from clothtool._jit import kernel
from clothtool._minmax import largest, smallest
from clothtool.solver.kernels.collide_shapes import capsule_axis


@kernel
def pose_points(world0, world1, frame, alpha, end, out):
    """out (m,3) = R^T (world0 + alpha (world1 - world0) - T) with the pose ``end``."""
    o = 4 * end
    for i in range(out.shape[0]):
        x = world0[i, 0] + alpha * (world1[i, 0] - world0[i, 0]) - frame[o + 3, 0]
        y = world0[i, 1] + alpha * (world1[i, 1] - world0[i, 1]) - frame[o + 3, 1]
        z = world0[i, 2] + alpha * (world1[i, 2] - world0[i, 2]) - frame[o + 3, 2]
        for d in range(3):
            out[i, d] = frame[o, d] * x + frame[o + 1, d] * y + frame[o + 2, d] * z


@kernel
def pose_spheres(world0, world1, frame, alpha, end, out):
    """out (s,4): centres as pose_points (which reads and writes columns 0-2 only), radii
    interpolated (at least 0)."""
    pose_points(world0, world1, frame, alpha, end, out)
    for i in range(out.shape[0]):
        out[i, 3] = largest(world0[i, 3] + alpha * (world1[i, 3] - world0[i, 3]), 0.0)


@kernel
def pose_planes(world0, world1, frame, alpha, end, out):
    """out (p,4): planes (n, d) interpolated, renormalised, then into the local frame."""
    o = 4 * end
    for i in range(out.shape[0]):
        nx = world0[i, 0] + alpha * (world1[i, 0] - world0[i, 0])
        ny = world0[i, 1] + alpha * (world1[i, 1] - world0[i, 1])
        nz = world0[i, 2] + alpha * (world1[i, 2] - world0[i, 2])
        d = world0[i, 3] + alpha * (world1[i, 3] - world0[i, 3])
        length = np.sqrt(nx * nx + ny * ny + nz * nz)
        if length > 0.0:
            nx /= length
            ny /= length
            nz /= length
            d /= length
        for c in range(3):
            out[i, c] = frame[o, c] * nx + frame[o + 1, c] * ny + frame[o + 2, c] * nz
        out[i, 3] = d - (nx * frame[o + 3, 0] + ny * frame[o + 3, 1] + nz * frame[o + 3, 2])


@kernel
def pack_spheres(start, end, colliders, params, out):
    """out (k,9) sphere records (collide_shapes) of spheres ``colliders`` (k,) from the posed
    spheres start/end (s,4): x0 y0 z0 r0+margin x1 y1 z1 r1+margin friction; params (k,2) is
    margin, friction."""
    for k in range(colliders.shape[0]):
        s = colliders[k]
        for d in range(3):
            out[k, d] = start[s, d]
            out[k, 4 + d] = end[s, d]
        out[k, 3] = start[s, 3] + params[k, 0]
        out[k, 7] = end[s, 3] + params[k, 0]
        out[k, 8] = params[k, 1]


@kernel
def pack_capsules(start, end, index, params, out):
    """out (c,24) capsule records (collide_shapes): end spheres index (c,2) of the posed
    spheres at the start then the end, radii plus margin, friction, and the end pose's axis
    terms (collide_shapes.capsule_axis); params (c,2) is margin, friction."""
    for c in range(index.shape[0]):
        for e in range(2):
            s = index[c, e]
            for d in range(3):
                out[c, 4 * e + d] = start[s, d]
                out[c, 8 + 4 * e + d] = end[s, d]
            out[c, 4 * e + 3] = start[s, 3] + params[c, 0]
            out[c, 8 + 4 * e + 3] = end[s, 3] + params[c, 0]
        out[c, 16] = params[c, 1]
        capsule_axis(out, c)


@kernel
def pack_triangles(points0, points1, triangles, params, out):
    """out (t,32) triangle records (collide_mesh): corners at the start and end, unit normals
    (b - a) x (c - a) at both (zero for a degenerate triangle), margin, friction (params), and
    the end corners' box grown by the margin."""
    for t in range(triangles.shape[0]):
        pack_triangle(
            points0, points1, triangles[t, 0], triangles[t, 1], triangles[t, 2], params[t, 0], params[t, 1], out, t
        )


@kernel(device=True)
def pack_triangle(points0, points1, a, b, c, margin, friction, out, row):
    """out[row] = the record of the triangle of points a, b, c (see pack_triangles); reads
    columns 0-2 of points0 and points1 only, so particle states (n,4) serve as they are."""
    for corner, p in enumerate((a, b, c)):
        for d in range(3):
            out[row, 3 * corner + d] = points0[p, d]
            out[row, 9 + 3 * corner + d] = points1[p, d]
    for pose in range(2):
        o = 9 * pose
        e1x = out[row, o + 3] - out[row, o]
        e1y = out[row, o + 4] - out[row, o + 1]
        e1z = out[row, o + 5] - out[row, o + 2]
        e2x = out[row, o + 6] - out[row, o]
        e2y = out[row, o + 7] - out[row, o + 1]
        e2z = out[row, o + 8] - out[row, o + 2]
        nx = e1y * e2z - e1z * e2y
        ny = e1z * e2x - e1x * e2z
        nz = e1x * e2y - e1y * e2x
        length = np.sqrt(nx * nx + ny * ny + nz * nz)
        scale = np.float32(1.0) / length if length > np.float32(1e-30) else np.float32(0.0)
        out[row, 18 + 3 * pose] = nx * scale
        out[row, 19 + 3 * pose] = ny * scale
        out[row, 20 + 3 * pose] = nz * scale
    out[row, 24] = margin
    out[row, 25] = friction
    for d in range(3):
        x = out[row, 9 + d]
        y = out[row, 12 + d]
        z = out[row, 15 + d]
        out[row, 26 + d] = smallest(x, y, z) - margin
        out[row, 29 + d] = largest(x, y, z) + margin


@kernel
def convex_translation(planes0, planes1, offsets, out):
    """out (k,3): each convex's translation from planes0 to planes1, the least-squares v with
    n_i . v = d1_i - d0_i over its planes (normals averaged and renormalised); components its
    normals do not see come out as zero (a plane collider moves only along its normal)."""
    for k in range(offsets.shape[0] - 1):
        m00 = m11 = m22 = 1e-4  # ridge: unseen components come out as zero, seen ones 1e-4 short
        m01 = m02 = m12 = 0.0
        b0 = b1 = b2 = 0.0
        for i in range(offsets[k], offsets[k + 1]):
            nx = 0.5 * (float(planes0[i, 0]) + float(planes1[i, 0]))  # float64: the solve is ill-conditioned
            ny = 0.5 * (float(planes0[i, 1]) + float(planes1[i, 1]))
            nz = 0.5 * (float(planes0[i, 2]) + float(planes1[i, 2]))
            length = np.sqrt(nx * nx + ny * ny + nz * nz)
            if length == 0.0:
                continue
            nx /= length
            ny /= length
            nz /= length
            shift = float(planes1[i, 3]) - float(planes0[i, 3])
            m00 += nx * nx
            m01 += nx * ny
            m02 += nx * nz
            m11 += ny * ny
            m12 += ny * nz
            m22 += nz * nz
            b0 += nx * shift
            b1 += ny * shift
            b2 += nz * shift
        # the symmetric 3x3 system by its adjugate
        c00 = m11 * m22 - m12 * m12
        c01 = m02 * m12 - m01 * m22
        c02 = m01 * m12 - m02 * m11
        c11 = m00 * m22 - m02 * m02
        c12 = m01 * m02 - m00 * m12
        c22 = m00 * m11 - m01 * m01
        det = m00 * c00 + m01 * c01 + m02 * c02
        out[k, 0] = (c00 * b0 + c01 * b1 + c02 * b2) / det
        out[k, 1] = (c01 * b0 + c11 * b1 + c12 * b2) / det
        out[k, 2] = (c02 * b0 + c12 * b1 + c22 * b2) / det


@kernel
def convex_shift(translation, frame, fraction, convex_data):
    """convex_data (k,5) columns 2-4 = R0^T (fraction * translation): each convex's own
    displacement over the iteration, in the frame's orientation at its start; columns 0-1
    (margin, friction) are left alone."""
    for k in range(convex_data.shape[0]):
        x = fraction * translation[k, 0]
        y = fraction * translation[k, 1]
        z = fraction * translation[k, 2]
        for d in range(3):
            convex_data[k, 2 + d] = frame[0, d] * x + frame[1, d] * y + frame[2, d] * z
