"""Reference for clothtool/solver/kernels/collide_mesh_faces.py: every collider point (owned
corners and edge samples) against every cloth triangle, no grid and no early rejection, with
the point-triangle contact of tests/reference/collide_mesh.py."""

from __future__ import annotations

import numpy as np

from tests.reference.collide import friction_correction
from tests.reference.collide_mesh import triangle_contact
from tests.reference.collide_pose import pack_triangles


def collider_points(triangle_data, owners, t):
    """[(start, end)] of collider triangle t's owned corners, then its edges' samples."""
    row = np.asarray(triangle_data[t], np.float64)
    start, end = row[0:9].reshape(3, 3), row[9:18].reshape(3, 3)
    points = [(start[k], end[k]) for k in range(3) if owners[t, 0] >> k & 1]
    for edge in range(3):
        n = owners[t, 1 + edge]
        i, j = edge, (edge + 1) % 3
        for k in range(n):
            s = (k + 1) / (n + 1)
            points.append(((1 - s) * start[i] + s * start[j], (1 - s) * end[i] + s * end[j]))
    return points


def collide_mesh_faces(cloth_triangles, owners, triangle_data, prev, mass_scale, meters_per_unit, cur):
    """The corrected particle state (a copy of ``cur``) and the number of triangles corrected."""
    cur = np.array(cur, np.float64)
    prev = np.asarray(prev, np.float64)
    corrected = 0
    for corners in np.asarray(cloth_triangles):
        w = np.array([cur[i, 3] if prev[i, 3] > 0 else 0.0 for i in corners])
        if (w <= 0).all():
            continue
        best, found = 0.0, None
        for t in range(triangle_data.shape[0]):
            margin, mu = float(triangle_data[t, 24]), float(triangle_data[t, 25])
            record = pack_triangles(prev[:, :3], cur[:, :3], corners[None], np.array([[margin, 0.0]]))
            for q, p in collider_points(triangle_data, owners, t):
                hit, *rest = triangle_contact(*p, *q, record, 0)
                if hit and np.dot(rest[:3], rest[:3]) > best:
                    best, found = float(np.dot(rest[:3], rest[:3])), (np.array(rest[:3]), rest[3], rest[4], p - q, mu)
        if found is None:
            continue
        push, u, v, surface, mu = found
        b = np.array([1 - u - v, u, v])
        m = b * w
        norm = float(b @ m)
        if norm <= 0:
            continue
        contact = b @ cur[corners, :3] - push
        previous = b @ prev[corners, :3]
        friction = np.array(friction_correction(*contact, *previous, *(-push), *surface, mu * np.sqrt(best)))
        correction = friction - push
        scale = 1.0 / (1.0 + mass_scale * best * meters_per_unit**2) if mass_scale > 0 else 1.0
        for i, mi, bi in zip(corners, m, b):
            if mi <= 0:
                continue
            cur[i, :3] += correction * mi / norm
            cur[i, 3] *= 1 + (scale - 1) * bi
        corrected += 1
    return cur, corrected


def _collider_point(T, t, k, owners):
    """The kernel's helper: point k of the owned corners (by corner index) and edge samples."""
    row = np.asarray(T[t], np.float64)
    start, end = row[0:9].reshape(3, 3), row[9:18].reshape(3, 3)
    if k < 3:
        return (True, *start[k], *end[k]) if owners[t, 0] >> k & 1 else (False,) + (0.0,) * 6
    samples = [(e, i) for e in range(3) for i in range(owners[t, 1 + e])]
    if k - 3 >= len(samples):
        return (False,) + (0.0,) * 6
    e, i = samples[k - 3]
    s = (i + 1) / (owners[t, 1 + e] + 1)
    j = (e + 1) % 3
    return (True, *((1 - s) * start[e] + s * start[j]), *((1 - s) * end[e] + s * end[j]))


def _misses(R, T, t):
    """The kernel's filter: every corner on one side of the start plane and beyond the margin
    at the end, or on its side at the end with the boxes apart."""
    r, row = np.asarray(R[0], np.float64), np.asarray(T[t], np.float64)
    h0 = (row[0:9].reshape(3, 3) - r[0:3]) @ r[18:21]
    h1 = (row[9:18].reshape(3, 3) - r[9:12]) @ r[21:24]
    margin = row[24]
    if (h0 >= 0).all():
        if h1.min() >= margin:
            return True
        near = h1.min() >= 0
    elif (h0 < 0).all():
        if h1.max() <= -margin:
            return True
        near = h1.max() < 0
    else:
        return False
    return bool(near and ((row[26:29] > r[29:32]) | (row[29:32] < r[26:29])).any())
