"""Reference for clothtool.solver.kernels.selfcollide, in float64 numpy.

``collide_points`` is brute force: every own particle against every point, O(n m), with no
grid at all, so that a grid that misses a neighbour (or finds one twice) shows up. The rule
(from NvCloth's self-collision and the kernel module's docstring): a pair (i, j) closer than
its distance D (segment_distance of j's cloth; own pairs also need a rest distance of at
least D) pushes i by c_ij = (x_i - x_j)(D/|x_i - x_j| - 1) w_i/(w_i + w_j); i moves by the
stiffness times the average of its c_ij weighted by the penetrations D - |x_i - x_j|.
"""

from __future__ import annotations

import numpy as np

CELL_LIMIT = 1.0e9
HASH = (1, 19349663, 83492791)


def transform_points(src, matrix, offset, w_scale, dst=None):
    """Returns (m,4): matrix @ xyz + offset, and w * w_scale."""
    src = np.asarray(src, np.float64)
    out = np.empty_like(src)
    out[:, :3] = src[:, :3] @ np.asarray(matrix, np.float64).T + np.asarray(offset, np.float64)
    out[:, 3] = src[:, 3] * float(w_scale)
    return out


def _cell_coordinate(x, inv_cell):
    """floor(x * inv_cell) clamped to +-1e9 (NaN to -1e9), as integers. Computed in float32,
    like the kernel, since a cell boundary is decided by the float32 product."""
    c = np.floor(np.float32(x) * np.float32(inv_cell)).astype(np.float64)
    c = np.where(c > -CELL_LIMIT, np.minimum(c, CELL_LIMIT), -CELL_LIMIT)
    return c.astype(np.int64)


def _bucket(cx, cy, cz, mask):
    """A cell's bucket: cx + cy Hy + cz Hz masked to the bucket count (cells next to each
    other along x fall in consecutive buckets)."""
    h = np.int64(cx) * HASH[0] + np.int64(cy) * HASH[1] + np.int64(cz) * HASH[2]
    return h & np.int64(mask)


def _rows_meet(a, b, mask):
    """Whether the bucket pairs {a, a + 1} and {b, b + 1} (mod mask + 1) share a bucket."""
    return bool({a, (a + 1) & mask} & {b, (b + 1) & mask})


def build_grid(points, inv_cell, bucket_start, order, sorted_points, sorted_cell):
    """Returns (bucket_start (B+1,), order (m,), sorted_points (m,4), sorted_cell (m,3)): the
    points sorted by the bucket of their cell (stable: by index within a bucket) as a CSR
    over B buckets, B = bucket_start's length - 1 (a power of two), with each slot's point
    index, point and cell."""
    points = np.asarray(points)
    buckets = np.asarray(bucket_start).shape[0] - 1
    cells = np.stack([_cell_coordinate(points[:, d], inv_cell) for d in range(3)], axis=1).reshape(-1, 3)
    keys = np.array([_bucket(*c, buckets - 1) for c in cells], np.int64)
    new_order = np.argsort(keys, kind="stable")
    starts = np.concatenate([[0], np.cumsum(np.bincount(keys, minlength=buckets))])
    return (
        starts.astype(np.int32),
        new_order.astype(np.int32),
        points[new_order].astype(np.float64),
        cells[new_order].astype(np.int32),
    )


def collide_points(
    sorted_points, sorted_cell, bucket_start, order, rest, point_segment, segment_distance, inv_cell, stiffness, cur
):
    """Brute force over all pairs: the grid is used only to put the points back in index
    order (point order[k] is sorted_points[k]). Returns cur as a float64 copy."""
    points = np.empty((np.asarray(order).shape[0], 4))
    points[np.asarray(order)] = np.asarray(sorted_points, np.float64)
    rest = np.asarray(rest, np.float64)
    out = np.array(cur, np.float64)
    own = out.shape[0]
    distance = np.asarray(segment_distance, np.float64)[np.asarray(point_segment)]  # (m,)
    for i in range(own):
        wi = points[i, 3]
        if wi == 0.0:
            continue
        e = points[i, :3] - points[:, :3]
        d = np.linalg.norm(e, axis=1)
        active = (d < distance) & (d > 0.0)
        active[i] = False
        rest_d = np.full(points.shape[0], np.inf)
        rest_d[:own] = np.linalg.norm(rest[i] - rest, axis=1)
        active &= rest_d >= distance
        if not active.any():
            continue
        e, d, dist, wj = e[active], d[active], distance[active], points[active, 3]
        depth = dist - d
        c = e * ((dist / d - 1.0) * wi / (wi + wj))[:, None]
        out[i, :3] += float(stiffness) * (depth[:, None] * c).sum(axis=0) / depth.sum()
    return out


collide_points_parallel = collide_points
