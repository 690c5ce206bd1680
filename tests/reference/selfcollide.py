"""Reference for clothtool.solver.kernels.selfcollide, in float64 numpy.

``collide_points`` is brute force: every own particle against every point, O(n m), with no
grid and no neighbour list at all, so that a list that misses a pair (or holds one twice)
shows up. The rule (from NvCloth's self-collision and the kernel module's docstring): a pair
(i, j) closer than its distance D (segment_distance of j's cloth; own pairs also need a rest
distance of at least D) pushes i by c_ij = (x_i - x_j)(D/|x_i - x_j| - 1) w_i/(w_i + w_j);
i moves by the stiffness times the average of its c_ij weighted by the penetrations
D - |x_i - x_j|. The list's pieces (``_list_pairs``, ``_list_rows`` and what uses them) are
brute force too: a row is every point within its distance + skin, sorted.
"""

from __future__ import annotations

import numpy as np

CELL_LIMIT = 1.0e9


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


def _bucket(cx, cy, cz, strides, mask):
    """A cell's bucket: its number in a grid of rows strides[0] and layers strides[1] cells
    long, masked to the bucket count (cells next to each other along x fall in consecutive
    buckets). Python integers, so no overflow (the kernel's int64 wraps, the same mod B)."""
    return (int(cx) + int(cy) * int(strides[0]) + int(cz) * int(strides[1])) & int(mask)


def grid_strides(points, inv_cell):
    """(row length, layer length): the points' cells along x and y, plus two each."""
    points = np.asarray(points)
    finite_x = points[~np.isnan(points[:, 0]), 0]
    finite_y = points[~np.isnan(points[:, 1]), 1]
    if finite_x.size == 0 or finite_y.size == 0:
        return 3, 9
    width = int(_cell_coordinate(finite_x.max(), inv_cell)) - int(_cell_coordinate(finite_x.min(), inv_cell)) + 3
    height = int(_cell_coordinate(finite_y.max(), inv_cell)) - int(_cell_coordinate(finite_y.min(), inv_cell)) + 3
    return width, width * height


def build_grid(points, inv_cell, bucket_start, order, sorted_points, sorted_cell, strides):
    """Returns (bucket_start (B+1,), order (m,), sorted_points (m,4), sorted_cell (m,3),
    strides (2,)): the points sorted by the bucket of their cell (stable: by index within a
    bucket) as a CSR over B buckets, B = bucket_start's length - 1 (a power of two), with
    each slot's point index, point and cell, and the grid's row and layer lengths."""
    points = np.asarray(points)
    buckets = np.asarray(bucket_start).shape[0] - 1
    steps = grid_strides(points, inv_cell)
    cells = np.stack([_cell_coordinate(points[:, d], inv_cell) for d in range(3)], axis=1).reshape(-1, 3)
    keys = np.array([_bucket(*c, steps, buckets - 1) for c in cells], np.int64)
    new_order = np.argsort(keys, kind="stable")
    starts = np.concatenate([[0], np.cumsum(np.bincount(keys, minlength=buckets))])
    return (
        starts.astype(np.int32),
        new_order.astype(np.int32),
        points[new_order].astype(np.float64),
        cells[new_order].astype(np.int32),
        np.array(steps, np.int64),
    )


REBUILD_FRACTION = 0.45


def _displaced(points, anchor, limit):
    """Whether some point lies farther than ``limit`` from its anchor (or is not finite)."""
    e = np.asarray(points, np.float64)[:, :3] - np.asarray(anchor, np.float64)[:, :3]
    return bool(np.any(~((e * e).sum(axis=1) <= float(limit) ** 2)))


def _runs_overlap(strides, mask):
    """Whether two of the nine runs of three buckets of a query (the cells x - 1..x + 1 of rows
    y - 1..y + 1, z - 1..z + 1) share a bucket, for a query at the origin (moving the cell
    adds the same amount to every bucket, mod B). Fewer than 8 buckets count as shared."""
    if mask < 8:
        return True
    runs = [{_bucket(x, y, z, strides, mask) for x in (-1, 0, 1)} for y in (-1, 0, 1) for z in (-1, 0, 1)]
    return any(runs[a] & runs[b] for a in range(9) for b in range(a + 1, 9))


def _close_at_rest(i, j, rest, distance):
    """Whether own particles i and j were closer than ``distance`` at rest."""
    r = np.asarray(rest, np.float64)[i] - np.asarray(rest, np.float64)[j]
    return bool(r @ r < float(distance) ** 2)


def _row(i, points, skin, rest, point_segment, segment_distance, own):
    """Row i of the list, ascending: the points within their distance + skin of point i,
    less i, points whose segment keeps no distance and own particles closer than the
    distance at rest."""
    points = np.asarray(points, np.float64)
    distance = np.asarray(segment_distance, np.float64)[np.asarray(point_segment)]
    d = np.linalg.norm(points[i, :3] - points[:, :3], axis=1)
    listed = (d < distance + float(skin)) & (distance > 0.0)
    listed[i] = False
    rest = np.asarray(rest, np.float64)
    listed[:own] &= np.linalg.norm(rest[i] - rest, axis=1) >= distance[:own]
    return np.flatnonzero(listed)


def _sort_rows(first, end, row_start, row_split, pairs):
    """Returns (row_split, pairs) copies with rows first..end-1 sorted and split at their
    first entry above the row."""
    row_split, pairs = np.array(row_split), np.array(pairs)
    for i in range(first, end):
        row = np.sort(pairs[row_start[i] : row_start[i + 1]])
        pairs[row_start[i] : row_start[i + 1]] = row
        row_split[i] = row_start[i] + np.searchsorted(row, i, side="right")
    return row_split, pairs


def _layout(first, points, skin, rest, point_segment, segment_distance, row_start, row_split, pairs):
    """(end, row_start, row_split, pairs): brute-force rows first.. from the start of a buffer
    of pairs' capacity while they fit (end = the first row that did not), as copies."""
    row_start, row_split, pairs = np.array(row_start), np.array(row_split), np.array(pairs)
    own = row_start.shape[0] - 1
    p = 0
    for i in range(first, own):
        row = _row(i, points, skin, rest, point_segment, segment_distance, own)
        row_start[i] = p
        if p + row.size > pairs.shape[0]:
            return i, row_start, row_split, pairs
        pairs[p : p + row.size] = row
        row_split[i] = p + np.searchsorted(row, i, side="right")
        p += row.size
        row_start[i + 1] = p
    return own, row_start, row_split, pairs


def _list_pairs(
    skin, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment, segment_distance, row_start,
    row_split, pairs, found,
):
    """Returns (entries the whole list needs, row_start, row_split, pairs): the list laid out
    in full when it fits both buffers (else the arrays as given)."""
    points = np.empty((np.asarray(order).shape[0], 4))
    points[np.asarray(order)] = np.asarray(sorted_points, np.float64)
    own = np.asarray(row_start).shape[0] - 1
    entries = sum(_row(i, points, skin, rest, point_segment, segment_distance, own).size for i in range(own))
    if entries > min(np.asarray(pairs).shape[0], np.asarray(found).shape[0]):
        return entries, np.array(row_start), np.array(row_split), np.array(pairs)
    return (entries, *_layout(0, points, skin, rest, point_segment, segment_distance, row_start, row_split, pairs)[1:])


def _list_rows(
    first, points, inv_cell, skin, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment,
    segment_distance, row_start, row_split, pairs,
):
    """Returns (end, row_start, row_split, pairs): rows first.. laid out from the start of a
    buffer of pairs' capacity while they fit (end = the first row that did not), as copies."""
    return _layout(first, points, skin, rest, point_segment, segment_distance, row_start, row_split, pairs)


def _refresh_list(
    points, anchor, skin, inv_cell, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment,
    segment_distance, row_start, row_split, pairs, found, list_state,
):
    """Returns (end, rebuilt): the rows listed from row 0 when the list must be rebuilt (not
    complete, or a point moved more than REBUILD_FRACTION * skin): all when the list fits
    both buffers, else as many as fit; (own, False) when it is kept."""
    own = np.asarray(row_start).shape[0] - 1
    if list_state[0] == 1 and not _displaced(points, anchor, REBUILD_FRACTION * float(skin)):
        return own, False
    end = _layout(0, points, skin, rest, point_segment, segment_distance, row_start, row_split, pairs)[0]
    entries = sum(_row(i, points, skin, rest, point_segment, segment_distance, own).size for i in range(own))
    return (own if entries <= min(len(pairs), len(found)) else end), True


def _next_rows(
    first, points, inv_cell, skin, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment,
    segment_distance, row_start, row_split, pairs,
):
    """The row after the next chunk of rows from ``first``."""
    return _layout(first, points, skin, rest, point_segment, segment_distance, row_start, row_split, pairs)[0]


def _terms(i, js, points, point_segment, segment_distance):
    """(sum of d_ij c_ij, sum of d_ij) over the points js of i's row (no rest filter here:
    the row was filtered when listed)."""
    points = np.asarray(points, np.float64)
    distance = np.asarray(segment_distance, np.float64)[np.asarray(point_segment)[js]]
    e = points[i, :3] - points[js, :3]
    d = np.linalg.norm(e, axis=1)
    active = (d < distance) & (d > 0.0)
    e, d, distance, wj = e[active], d[active], distance[active], points[js][active, 3]
    depth = distance - d
    c = e * ((distance / d - 1.0) * points[i, 3] / (points[i, 3] + wj))[:, None]
    return (depth[:, None] * c).sum(axis=0), depth.sum()


def _pair_sums(first, end, points, row_start, row_split, pairs, point_segment, segment_distance, sums):
    """Returns sums (float64 copy) with each listed pair's two shares added: rows
    first..end-1, each pair (i, j > i) adding to i and, for an own j, to j."""
    sums = np.array(sums, np.float64)
    own = np.asarray(row_start).shape[0] - 1
    for i in range(first, end):
        for j in np.asarray(pairs)[row_split[i] : row_start[i + 1]]:
            for a, b in ((i, j), (j, i)) if j < own else ((i, j),):
                push, depth = _terms(a, np.array([b]), points, point_segment, segment_distance)
                sums[a, :3] += push
                sums[a, 3] += depth
    return sums


def _gather_rows(first, end, points, row_start, pairs, point_segment, segment_distance, stiffness, cur):
    """Returns cur (float64 copy) with rows first..end-1 moved by their whole row's terms."""
    out = np.array(cur, np.float64)
    for i in range(first, end):
        if points[i, 3] == 0.0:
            continue
        push, weight = _terms(i, np.asarray(pairs)[row_start[i] : row_start[i + 1]], points, point_segment,
                              segment_distance)
        if weight > 0.0:
            out[i, :3] += float(stiffness) * push / weight
    return out


def collide_points(
    points, anchor, skin, inv_cell, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment,
    segment_distance, stiffness, row_start, row_split, pairs, found, list_state, sums, cur,
):
    """Brute force over all pairs, from ``points`` (no list, no grid). Returns cur as a
    float64 copy."""
    points = np.asarray(points, np.float64)
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
