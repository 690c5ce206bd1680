"""Reference for clothtool.solver.kernels.wind: the seed's applyWind with the physical air law.

Per triangle, in order: its centre's motion over the iteration relative to the air,

    d = c_t - p_t + (frame motion at c_t) - air        (the seed's "+ wind" is NvCloth's
                                                        frame translation minus wind * dt)

the unnormalised normal n = (c2 - c0) x (c1 - c0), a = |n| (twice the area), and, written
with angles as the textbook does,

    cos = n^ . d / |d| ;  sin = sqrt(max(0, 1 - cos^2)) ;  l^ = unit((d x n^) x d)
    i   = (c_drag |cos| |d| d + c_lift cos sin |d|^2 l^) * a * density   (tests/reference/air.py)

(the drag and lift of 1/2 rho C A v^2 with v = d / h, a third per corner: density is
rho s^3 / 12, see the kernel). Each corner j moves by -i times its inverse mass (cur.w) and
its share (clothtool.solver.air; 1 on a triangle mesh) — scaled down, where it would, so
that the centre moves by at most |d| (air can at most stop
the triangle's relative motion). A triangle without area or relative motion gets nothing;
there is no speed threshold (the seed's FLT_EPSILON cut-off is gone).

The loop is deliberately sequential: a triangle's centre and normal are read from positions
that the triangles before it have already pushed, so the result depends on the order. The
kernel takes the triangles in colours that share no movable particle (cur.w > 0); this
reference checks that and otherwise ignores them (within a colour the order cannot matter).
"""

from __future__ import annotations

import numpy as np

from tests.reference import air


def air_push(d, normal, drag, lift, density):
    """i (3,) of the module docstring for the relative motion d and unnormalised normal."""
    gx, gy, gz, ok = air.triangle_air(*d, *normal, drag, lift)
    return np.array([gx, gy, gz]) * density if ok else np.zeros(3)


def capped(impulse, length, mean_inverse_mass):
    """The impulse scaled so that the centre moves at most |d|."""
    shift = np.linalg.norm(impulse) * mean_inverse_mass
    return impulse * (length / shift) if shift > length else impulse


def triangle_impulse(c, p, frame_matrix, frame_offset, air_offset, drag, lift, density):
    """(impulse (3,), |d|) of one triangle from its current (3,3) and previous (3,3) corners."""
    centre = c.sum(axis=0) / 3.0
    d = centre - p.sum(axis=0) / 3.0 + frame_matrix @ centre + frame_offset - air_offset
    n = np.cross(c[2] - c[0], c[1] - c[0])
    return air_push(d, n, drag, lift, density), float(np.linalg.norm(d))


def apply_wind(triangles, color_offsets, share, frame_matrix, frame_offset, air_offset, drag, lift, density, cur, prev):
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
        np.asarray(air_offset, np.float64), float(drag), float(lift), float(density),
    )
    share = np.asarray(share, np.float64)
    for tri in np.asarray(triangles):
        impulse, length = triangle_impulse(cur[tri, :3], prev[tri, :3], *args)
        impulse = capped(impulse, length, (cur[tri, 3] * share[tri]).mean())
        for j in tri:
            cur[j, :3] -= impulse * cur[j, 3] * share[j]
    return cur


def _gather(triangles, share, lo, hi, frame_matrix, frame_offset, air_offset, cur, prev, scratch=None):
    """Per triangle lo..hi: (d (k,3), unnormalised normal (k,3), mean over its corners of
    inverse mass times share (k,)) from the flat (n*4,) particle views."""
    c = np.asarray(cur, np.float64).reshape(-1, 4)
    p = np.asarray(prev, np.float64).reshape(-1, 4)
    tri = np.asarray(triangles)[lo:hi]
    centre = c[tri, :3].mean(axis=1)
    d = centre - p[tri, :3].mean(axis=1) + centre @ np.asarray(frame_matrix, np.float64).T + frame_offset - air_offset
    normal = np.cross(c[tri[:, 2], :3] - c[tri[:, 0], :3], c[tri[:, 1], :3] - c[tri[:, 0], :3])
    return d, normal, (c[tri, 3] * np.asarray(share, np.float64)[tri]).mean(axis=1)


def _impulses(d, normal, mean_inverse_mass, drag, lift, density):
    """(k,3) impulses from _gather's (d, normal, mean inverse mass): air_push, capped so that
    the centre moves at most |d|. (The kernel's helper reads the same values from its block
    scratch.)"""
    out = np.zeros((len(d), 3))
    for j, (dj, nj, wj) in enumerate(zip(d, normal, mean_inverse_mass)):
        out[j] = capped(air_push(dj, nj, drag, lift, density), float(np.linalg.norm(dj)), wj)
    return out
