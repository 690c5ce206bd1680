"""Reference for clothtool.solver.kernels.wind: the seed's "Wind simulation" (applyWind).

Per triangle, in order: its centre's motion over the iteration relative to the air,

    d = c_t - p_t + (frame motion at c_t) - air        (the seed's "+ wind" is NvCloth's
                                                        frame translation minus wind * dt)

the unnormalised normal n = (c2 - c0) x (c1 - c0), a = |n| (twice the area), and

    cos = n^ . d / |d| ;  sin = sqrt(max(0, 1 - cos^2)) ;  l_dir = ((d x n^) x d) / |d|
    i   = (c_lift cos sin l_dir |d| + c_drag |cos| d |d|) / dt * rho * a

unless |d|^2 is below FLT_EPSILON (the seed's guard against float division noise; its table
prints the comparison the wrong way round, its prose says "if |d| is too small"), and each
corner moves by -i times its inverse mass (cur.w) — scaled down, where it would, so that the
centre moves by at most |d| (air can at most stop the triangle's relative motion).

The loop is deliberately sequential: a triangle's centre and normal are read from positions
that the triangles before it have already pushed, so the result depends on the order. The
kernel takes the triangles in colours that share no movable particle (cur.w > 0); this
reference checks that and otherwise ignores them (within a colour the order cannot matter).
A degenerate triangle (a = 0) has no normal; its impulse, proportional to a, is zero.
"""

from __future__ import annotations

import numpy as np

FLT_EPSILON = float(np.finfo(np.float32).eps)


def triangle_impulse(c, p, frame_matrix, frame_offset, air_offset, inv_dt, drag, lift, density):
    """Impulse (3,) of one triangle from its current (3,3) and previous (3,3) corners."""
    centre = c.sum(axis=0) / 3.0
    d = centre - p.sum(axis=0) / 3.0 + frame_matrix @ centre + frame_offset - air_offset
    n = np.cross(c[2] - c[0], c[1] - c[0])
    double_area = np.linalg.norm(n)
    length_sqr = float(d @ d)
    if length_sqr < FLT_EPSILON or double_area == 0.0:
        return np.zeros(3), 0.0
    n_hat = n / double_area
    length = np.sqrt(length_sqr)
    cos_theta = float(n_hat @ d) / length
    sin_theta = np.sqrt(max(0.0, 1.0 - cos_theta * cos_theta))
    lift_dir = np.cross(np.cross(d, n_hat), d) / length
    i_lift = lift * cos_theta * sin_theta * lift_dir * length * inv_dt
    i_drag = drag * abs(cos_theta) * d * length * inv_dt
    return (i_lift + i_drag) * density * double_area, length


def apply_wind(triangles, color_offsets, frame_matrix, frame_offset, air_offset, inv_dt, drag, lift, density, cur, prev):
    """Returns cur (float64 copy) after every triangle's impulse, applied in triangle order."""
    triangles = np.asarray(triangles)
    movable = np.asarray(cur)[:, 3] > 0
    for k in range(len(color_offsets) - 1):
        corners = triangles[color_offsets[k] : color_offsets[k + 1]].ravel()
        corners = corners[movable[corners]]
        if np.unique(corners).size != corners.size:
            raise ValueError("a colour's triangles share a movable particle")
    if len(color_offsets) and (color_offsets[0] != 0 or color_offsets[-1] != triangles.shape[0]):
        raise ValueError("the colours do not cover the triangles")
    cur = np.array(cur, np.float64)
    prev = np.asarray(prev, np.float64)
    args = (
        np.asarray(frame_matrix, np.float64), np.asarray(frame_offset, np.float64),
        np.asarray(air_offset, np.float64), float(inv_dt), float(drag), float(lift), float(density),
    )
    for tri in np.asarray(triangles):
        impulse, length = triangle_impulse(cur[tri, :3], prev[tri, :3], *args)
        shift = np.linalg.norm(impulse) * cur[tri, 3].mean()
        if shift > length:
            impulse = impulse * (length / shift)
        for j in tri:
            cur[j, :3] -= impulse * cur[j, 3]
    return cur


def _gather(triangles, lo, hi, frame_matrix, frame_offset, air_offset, cur, prev, scratch=None):
    """Per triangle lo..hi: (d (k,3), unnormalised normal (k,3), mean inverse mass (k,)) from
    the flat (n*4,) particle views."""
    c = np.asarray(cur, np.float64).reshape(-1, 4)
    p = np.asarray(prev, np.float64).reshape(-1, 4)
    tri = np.asarray(triangles)[lo:hi]
    centre = c[tri, :3].mean(axis=1)
    d = centre - p[tri, :3].mean(axis=1) + centre @ np.asarray(frame_matrix, np.float64).T + frame_offset - air_offset
    normal = np.cross(c[tri[:, 2], :3] - c[tri[:, 0], :3], c[tri[:, 1], :3] - c[tri[:, 0], :3])
    return d, normal, c[tri, 3].mean(axis=1)


def _impulses(d, normal, mean_inverse_mass, inv_dt, drag, lift, density):
    """(k,3) impulses from _gather's (d, normal, mean inverse mass): triangle_impulse's
    formula, zero below the epsilon or without area, capped so that the centre moves at most
    |d|. (The kernel's helper reads the same values from its block scratch.)"""
    out = np.zeros((len(d), 3))
    for j, (dj, nj, wj) in enumerate(zip(d, normal, mean_inverse_mass)):
        double_area = np.linalg.norm(nj)
        length_sqr = float(dj @ dj)
        if length_sqr < FLT_EPSILON or double_area == 0.0:
            continue
        length = np.sqrt(length_sqr)
        n_hat = nj / double_area
        cos_theta = float(n_hat @ dj) / length
        sin_theta = np.sqrt(max(0.0, 1.0 - cos_theta * cos_theta))
        lift_dir = np.cross(np.cross(dj, n_hat), dj) / length
        impulse = (lift * cos_theta * sin_theta * lift_dir + drag * abs(cos_theta) * dj) * length * inv_dt * density * double_area
        shift = np.linalg.norm(impulse) * wj
        out[j] = impulse * (length / shift) if shift > length else impulse
    return out
