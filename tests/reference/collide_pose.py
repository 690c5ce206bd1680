"""References for clothtool/solver/kernels/collide_pose.py: the frame's poses as rotation
matrices and translations (local x -> world R x + T), applied with numpy."""

from __future__ import annotations

import numpy as np


def _pose(frame, end):
    f = np.asarray(frame, np.float64)
    return f[4 * end: 4 * end + 3], f[4 * end + 3]


def _lerp(world0, world1, alpha):
    w0, w1 = np.asarray(world0, np.float64), np.asarray(world1, np.float64)
    return w0 + alpha * (w1 - w0)


def pose_points(world0, world1, frame, alpha, end):
    rotation, translation = _pose(frame, end)
    return (_lerp(world0, world1, alpha) - translation) @ rotation


def pose_spheres(world0, world1, frame, alpha, end):
    spheres = _lerp(world0, world1, alpha)
    out = np.empty_like(spheres)
    out[:, :3] = pose_points(world0[:, :3], world1[:, :3], frame, alpha, end)
    out[:, 3] = np.maximum(spheres[:, 3], 0.0)
    return out


def pose_planes(world0, world1, frame, alpha, end):
    """Planes n.x = d renormalised; in the frame x_local = R^T (x - T), the plane's points
    x = R x_local + T satisfy (R^T n) . x_local = d - n . T."""
    rotation, translation = _pose(frame, end)
    planes = _lerp(world0, world1, alpha)
    planes = planes / np.linalg.norm(planes[:, :3], axis=1, keepdims=True)
    out = np.empty_like(planes)
    out[:, :3] = planes[:, :3] @ rotation
    out[:, 3] = planes[:, 3] - planes[:, :3] @ translation
    return out


def pack_spheres(start, end, colliders, params):
    s, e, p = (np.asarray(a, np.float64) for a in (start, end, params))
    out = np.concatenate([s[colliders], e[colliders], p[:, 1:2]], axis=1)
    out[:, 3] += p[:, 0]
    out[:, 7] += p[:, 0]
    return out


def pack_capsules(start, end, index, params):
    s, e, p = (np.asarray(a, np.float64) for a in (start, end, params))
    grow = np.array([0, 0, 0, 1.0])
    parts = [s[index[:, 0]], s[index[:, 1]], e[index[:, 0]], e[index[:, 1]]]
    parts = [part + p[:, :1] * grow for part in parts]
    return np.concatenate(parts + [p[:, 1:2], capsule_axes(parts[2], parts[3])], axis=1)


def capsule_axes(a, b):
    """The capsule records' end-pose axis terms (collide_shapes.capsule_axis) of end spheres
    a, b (k,4): unit axis, length (-1 when one sphere holds the other), sin and cos of the
    taper, square of 1.25 times the larger radius."""
    axis = b[:, :3] - a[:, :3]
    length = np.linalg.norm(axis, axis=1)
    nested = (length <= np.abs(a[:, 3] - b[:, 3])) | (length <= 1e-12)
    safe = np.where(nested, 1.0, length)
    sin_a = np.where(nested, 0.0, (a[:, 3] - b[:, 3]) / safe)
    return np.column_stack([
        np.where(nested[:, None], 0.0, axis / safe[:, None]), np.where(nested, -1.0, length), sin_a,
        np.where(nested, 0.0, np.sqrt(np.maximum(1.0 - sin_a ** 2, 0.0))), (1.25 * np.maximum(a[:, 3], b[:, 3])) ** 2,
    ])


def pack_triangles(points0, points1, triangles, params):
    p0, p1, prm = (np.asarray(a, np.float64) for a in (points0, points1, params))
    out = np.zeros((triangles.shape[0], 32))
    for pose, points in enumerate((p0, p1)):
        corners = points[triangles]
        out[:, 9 * pose: 9 * pose + 9] = corners.reshape(-1, 9)
        normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        length = np.linalg.norm(normal, axis=1, keepdims=True)
        out[:, 18 + 3 * pose: 21 + 3 * pose] = np.where(length > 1e-30, normal / np.where(length > 0, length, 1), 0)
    out[:, 24:26] = prm
    corners = p1[triangles]
    out[:, 26:29] = corners.min(axis=1) - prm[:, :1]
    out[:, 29:32] = corners.max(axis=1) + prm[:, :1]
    return out


def convex_translation(planes0, planes1, offsets):
    """Least-norm least-squares translation per convex: n_i . v = d1_i - d0_i."""
    p0, p1 = np.asarray(planes0, np.float64), np.asarray(planes1, np.float64)
    out = np.zeros((len(offsets) - 1, 3))
    for k in range(len(offsets) - 1):
        rows = slice(offsets[k], offsets[k + 1])
        normals = p0[rows, :3] + p1[rows, :3]
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        out[k], *_ = np.linalg.lstsq(normals, p1[rows, 3] - p0[rows, 3], rcond=None)
    return out


def convex_shift(translation, frame, fraction, convex_data):
    rotation, _ = _pose(frame, 0)
    out = np.asarray(convex_data, np.float64).copy()
    out[:, 2:5] = (fraction * np.asarray(translation, np.float64)) @ rotation
    return out


def pack_triangle(points0, points1, a, b, c, margin, friction, out, row):
    out[row] = pack_triangles(np.asarray(points0)[:, :3], np.asarray(points1)[:, :3], np.array([[a, b, c]]), [[margin, friction]])[0]
