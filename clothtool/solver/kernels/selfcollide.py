"""Self- and cloth-cloth collision: particles keep a minimum distance, found on a hashed grid.

The stage gathers the points it tests into one array ``points`` (m,4): the cloth's own
particles first (a snapshot of cur, inverse mass in w), then the particles of neighbouring
cloths, moved into this cloth's frame. ``point_segment`` (m,) says which cloth a point
belongs to (0 = this cloth) and ``segment_distance`` gives, per segment, the distance this
cloth keeps from that segment's points (0 = ignore them).

Grid: cell size = twice the largest distance. Cell (cx, cy, cz) hashes into one of B
buckets (B a power of two), and the points are counting-sorted by bucket (stable: by index
within a bucket) into contiguous copies. Every point closer than the distance to a point p
lies in the 2 x 2 x 2 block of cells around the cell corner nearest to p (per axis, p's
cell and the neighbour on the side of the half p lies in), so a query scans 8 cells (not
the 27 of cells as large as the distance), keeping only the points whose cell matches
exactly (two cells sharing a bucket never yield a point twice). The hash is
cx + cy * Hy + cz * Hz (mod B): cells (cx, cy, cz) and (cx + 1, cy, cz) fall in consecutive
buckets, so the block is 4 contiguous runs of the sorted points, not 8 (the per-bucket loop
exits, hard to predict, were a third of a query's time). Cost O(m + B) to build, O(m) to
query for a bounded number of points per cell.

Response, per own particle i (Jacobi, so the result does not depend on the order or on the
thread count): over its neighbours j closer than the pair's distance D (and, for two
particles of this cloth, no closer than D in the rest pose, NvCloth's rest filter)

    c_ij = (x_i - x_j) (D / |x_i - x_j| - 1) w_i / (w_i + w_j)      (i's share of the push)
    x_i += k * sum_j d_ij c_ij / sum_j d_ij,     d_ij = D - |x_i - x_j| (the penetration)

i.e. the share of a distance constraint's correction that moves i, averaged over the
constraints acting on i, weighted by their penetration. A particle pressed against a sheet
meets several of its particles at once: summing their corrections (Jacobi) would overshoot
and jitter, and a plain average (Macklin et al. 2014) would jump whenever a pair crosses the
distance; the weighted average is continuous and never exceeds the largest correction.
Positions are read from the snapshot and written to cur, so every particle sees the state
at the start of the stage. Pinned particles (w = 0) do not move; coincident points (no
direction to separate along) are skipped.
"""

from __future__ import annotations

import numba
import numpy as np

from clothtool._jit import kernel, serial_and_parallel

CELL_LIMIT = np.float32(1.0e9)  # cell coordinates are clamped to +-this (and NaN maps to -it)
HASH_Y = np.int64(19349663)  # large odd multipliers: rows and layers of cells spread out
HASH_Z = np.int64(83492791)


@kernel
def transform_points(src, matrix, offset, w_scale, dst):
    """dst[i] = (matrix @ src[i,:3] + offset, src[i,3] * w_scale): a neighbour's particles in
    this cloth's frame; w_scale = 0 makes them immovable (a sleeping neighbour)."""
    for i in range(src.shape[0]):
        x = src[i, 0]
        y = src[i, 1]
        z = src[i, 2]
        for d in range(3):
            dst[i, d] = matrix[d, 0] * x + matrix[d, 1] * y + matrix[d, 2] * z + offset[d]
        dst[i, 3] = src[i, 3] * w_scale


@kernel(inline="always")
def _cell_coordinate(x, inv_cell):
    c = np.floor(x * inv_cell)
    if not c > -CELL_LIMIT:  # also NaN
        c = -CELL_LIMIT
    elif c > CELL_LIMIT:
        c = CELL_LIMIT
    return np.int32(c)


@kernel(inline="always")
def _bucket(cx, cy, cz, mask):
    return (np.int64(cx) + np.int64(cy) * HASH_Y + np.int64(cz) * HASH_Z) & mask


@kernel(inline="always")
def _rows_meet(a, b, mask):
    """Whether the bucket pairs (a, a + 1) and (b, b + 1) (mod the bucket count) share one."""
    return a == b or a == ((b + 1) & mask) or ((a + 1) & mask) == b


@kernel
def build_grid(points, inv_cell, bucket_start, order, sorted_points, sorted_cell):
    """Hash points into cells of size 1/inv_cell and counting-sort them by bucket.

    bucket_start i32 (B+1,), B a power of two: bucket b holds sorted slots
    bucket_start[b]:bucket_start[b+1]; order i32 (m,): the point in each sorted slot (by
    index within a bucket); sorted_points (m,4) and sorted_cell i32 (m,3): each slot's point
    and cell, so that a bucket's points are contiguous in memory.
    """
    buckets = bucket_start.shape[0] - 1
    mask = np.int64(buckets - 1)
    for b in range(bucket_start.shape[0]):
        bucket_start[b] = 0
    for i in range(points.shape[0]):
        cx = _cell_coordinate(points[i, 0], inv_cell)
        cy = _cell_coordinate(points[i, 1], inv_cell)
        cz = _cell_coordinate(points[i, 2], inv_cell)
        bucket_start[_bucket(cx, cy, cz, mask) + 1] += 1
    for b in range(buckets):
        bucket_start[b + 1] += bucket_start[b]
    # scatter with bucket_start[b] as bucket b's cursor, then shift the ends back to starts
    for i in range(points.shape[0]):
        cx = _cell_coordinate(points[i, 0], inv_cell)
        cy = _cell_coordinate(points[i, 1], inv_cell)
        cz = _cell_coordinate(points[i, 2], inv_cell)
        b = _bucket(cx, cy, cz, mask)
        k = bucket_start[b]
        bucket_start[b] = k + 1
        order[k] = i
        for d in range(4):
            sorted_points[k, d] = points[i, d]
        sorted_cell[k, 0] = cx
        sorted_cell[k, 1] = cy
        sorted_cell[k, 2] = cz
    for b in range(buckets, 0, -1):
        bucket_start[b] = bucket_start[b - 1]
    bucket_start[0] = 0


def _collide_points(
    sorted_points, sorted_cell, bucket_start, order, rest, point_segment, segment_distance, inv_cell, stiffness, cur
):
    """Push each own particle i < cur.shape[0] away from the points closer than their
    segment's distance (see the module docstring); reads the grid, updates ``cur``.

    The cell size 1/inv_cell must be at least twice the largest segment distance: then the
    points within reach of a point lie in the 2 x 2 x 2 cells around the corner of its cell
    it is nearest to. Particles are visited in grid order, for locality.
    """
    zero = np.float32(0.0)
    one = np.float32(1.0)
    half = np.float32(0.5)
    mask = np.int64(bucket_start.shape[0] - 2)
    own = cur.shape[0]
    one_segment = segment_distance.shape[0] == 1  # a cloth alone: one distance for every pair
    only_distance = segment_distance[0] if one_segment else zero
    for slot in numba.prange(sorted_points.shape[0]):
        i = order[slot]
        wi = sorted_points[slot, 3]
        if i >= own or wi == zero:
            continue
        xi = sorted_points[slot, 0]
        yi = sorted_points[slot, 1]
        zi = sorted_points[slot, 2]
        # the lower corner of the 2 x 2 x 2 block: the neighbour cell on the nearer side
        x0 = sorted_cell[slot, 0] - (1 if xi * inv_cell - sorted_cell[slot, 0] < half else 0)
        y0 = sorted_cell[slot, 1] - (1 if yi * inv_cell - sorted_cell[slot, 1] < half else 0)
        z0 = sorted_cell[slot, 2] - (1 if zi * inv_cell - sorted_cell[slot, 2] < half else 0)
        sx = zero
        sy = zero
        sz = zero
        weight = zero
        # A point of another cell hashed into a scanned bucket is out of reach (everything in
        # reach lies in the block), so only a bucket scanned twice could count a point twice:
        # the cell test is needed only when two of the four rows' buckets meet (rare; ~40% of
        # the query's time when done for every candidate)
        b00 = _bucket(x0, y0, z0, mask)
        b10 = _bucket(x0, y0 + 1, z0, mask)
        b01 = _bucket(x0, y0, z0 + 1, mask)
        b11 = _bucket(x0, y0 + 1, z0 + 1, mask)
        check = (
            _rows_meet(b00, b10, mask) or _rows_meet(b00, b01, mask) or _rows_meet(b00, b11, mask)
            or _rows_meet(b10, b01, mask) or _rows_meet(b10, b11, mask) or _rows_meet(b01, b11, mask)
        )
        for tz in range(z0, z0 + 2):
            for ty in range(y0, y0 + 2):
                # cells x0 and x0 + 1 are buckets b and b + 1: one run of slots unless b + 1
                # wraps around to bucket 0 (then the second cell is a run of its own)
                b = _bucket(x0, ty, tz, mask)
                wraps = b == mask
                for run in range(2 if wraps else 1):
                    if run == 0:
                        first, last = bucket_start[b], bucket_start[b + 1 if wraps else b + 2]
                    else:
                        first, last = bucket_start[0], bucket_start[1]
                    for k in range(first, last):
                        if check:
                            tx = sorted_cell[k, 0]
                            if (tx != x0 and tx != x0 + 1) or sorted_cell[k, 1] != ty or sorted_cell[k, 2] != tz:
                                continue
                        # most candidates are out of reach: decide that before loading more
                        distance = only_distance if one_segment else segment_distance[point_segment[order[k]]]
                        ex = xi - sorted_points[k, 0]
                        ey = yi - sorted_points[k, 1]
                        ez = zi - sorted_points[k, 2]
                        d2 = ex * ex + ey * ey + ez * ez
                        if k == slot or not (d2 < distance * distance and d2 > zero):
                            continue
                        j = order[k]
                        if j < own:
                            rx = rest[i, 0] - rest[j, 0]
                            ry = rest[i, 1] - rest[j, 1]
                            rz = rest[i, 2] - rest[j, 2]
                            if rx * rx + ry * ry + rz * rz < distance * distance:
                                continue
                        d = np.sqrt(d2)
                        depth = distance - d
                        factor = depth * (distance / d - one) * wi / (wi + sorted_points[k, 3])
                        sx += ex * factor
                        sy += ey * factor
                        sz += ez * factor
                        weight += depth
        if weight > zero:
            scale = stiffness / weight
            cur[i, 0] += sx * scale
            cur[i, 1] += sy * scale
            cur[i, 2] += sz * scale




collide_points, collide_points_parallel = serial_and_parallel(_collide_points)
