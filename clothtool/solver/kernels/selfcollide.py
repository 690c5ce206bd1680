"""Self- and cloth-cloth collision: particles keep a minimum distance, found through a
neighbour list that is rebuilt from a hashed grid only when the points have moved.

The stage gathers the points it tests into one array ``points`` (m,4): the cloth's own
particles first (a snapshot of cur, inverse mass in w), then the particles of neighbouring
cloths, moved into this cloth's frame. ``point_segment`` (m,) says which cloth a point
belongs to (0 = this cloth) and ``segment_distance`` gives, per segment, the distance this
cloth keeps from that segment's points (0 = ignore them).

Neighbour list (a Verlet list): row i (one per own particle) lists, in ascending order, the
points j that were closer than their distance D plus a ``skin`` when the list was built from
the positions then (``anchor``), leaving out for good the pairs of own particles closer than
D in the rest pose (NvCloth's rest filter: neighbours at rest are not fought over). While no
point has moved more than ``REBUILD_FRACTION`` (a little under half) of the skin since, every
pair closer than D now is in the list, so an iteration reads only the list's few entries per
particle instead of querying the grid. Each row is sorted, so a particle meets its pairs in
the order of their indices whenever and from wherever the list was built: the result does not
depend on when it was rebuilt (nor on the grid, the skin or the thread count).

Grid (used to build the list): cell size = twice the list's reach (largest distance + skin).
Cell (cx, cy, cz) hashes into one of B buckets (B a power of two), and the points are
counting-sorted by bucket (stable: by index within a bucket) into contiguous copies. Every
point within reach of a point p lies in the 2 x 2 x 2 block of cells around the cell corner
nearest to p (per axis, p's cell and the neighbour on the side of the half p lies in), so a
query scans 8 cells, keeping only the points whose cell matches exactly (two cells sharing a
bucket never yield a point twice). The hash is cx + cy * Hy + cz * Hz (mod B): cells
(cx, cy, cz) and (cx + 1, cy, cz) fall in consecutive buckets, so the block is 4 contiguous
runs of the sorted points, not 8. Cost O(m + B) to build, O(m) to query for a bounded number
of points per cell.

The list lives in a buffer of fixed capacity (at least m entries, so that any one row fits):
when the rows do not all fit, the kernel lists and collides them a chunk of rows at a time
within the iteration (same pairs, same order, same result), rebuilds at every iteration while
that lasts, and records the entries it needed so that the stage can grow the buffer.

Response, per own particle i (Jacobi, so the result does not depend on the order of the rows
or on the thread count): over its listed points j closer than the pair's distance D

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

Serial, each pair of own particles is computed once (like NvCloth's sweep) and its two
shares are added to both particles' sums, rows in ascending order: every particle still
receives its terms in ascending order of the other index. The parallel kernel gathers each
row's terms on its own (every own pair computed twice, no shared writes), in that same order
with the same operations, so both give the same bits.
"""


from __future__ import annotations

import numba
import numpy as np

from clothtool._jit import kernel

CELL_LIMIT = np.float32(1.0e9)  # cell coordinates are clamped to +-this (and NaN maps to -it)
HASH_Y = np.int64(19349663)  # large odd multipliers: rows and layers of cells spread out
HASH_Z = np.int64(83492791)
# the list is rebuilt once a point has moved this much of the skin: a little under half, so
# that two points' moves (each below it) never bring an unlisted pair within its distance,
# float rounding included
REBUILD_FRACTION = np.float32(0.45)


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


@kernel
def _displaced(points, anchor, limit):
    """Whether some point lies farther than ``limit`` from its anchor (or is not finite)."""
    limit2 = limit * limit
    for i in range(points.shape[0]):
        dx = points[i, 0] - anchor[i, 0]
        dy = points[i, 1] - anchor[i, 1]
        dz = points[i, 2] - anchor[i, 2]
        if not dx * dx + dy * dy + dz * dz <= limit2:
            return True
    return False


@kernel
def _list_rows(
    first, points, inv_cell, skin, bucket_start, order, sorted_points, sorted_cell, rest, point_segment,
    segment_distance, own, row_start, row_split, pairs,
):
    """List rows first, first + 1, ... into ``pairs`` from its start while they fit; returns
    the row after the last one listed (``own`` when all did).

    Row i holds pairs[row_start[i]:row_start[i + 1]], ascending, the points of the grid (built
    from ``points``) within their distance + skin of point i, less i itself, points whose
    segment keeps no distance and own particles closer than the distance at rest;
    row_split[i] is the first entry above i. The grid's cells must be at least twice the
    largest distance + skin.
    """
    zero = np.float32(0.0)
    half = np.float32(0.5)
    mask = np.int64(bucket_start.shape[0] - 2)
    one_segment = segment_distance.shape[0] == 1  # a cloth alone: one distance for every pair
    only_distance = segment_distance[0] if one_segment else zero
    capacity = pairs.shape[0]
    p = 0
    for i in range(first, own):
        row_start[i] = p
        xi = points[i, 0]
        yi = points[i, 1]
        zi = points[i, 2]
        cx = _cell_coordinate(xi, inv_cell)
        cy = _cell_coordinate(yi, inv_cell)
        cz = _cell_coordinate(zi, inv_cell)
        # the lower corner of the 2 x 2 x 2 block: the neighbour cell on the nearer side
        x0 = cx - (1 if xi * inv_cell - cx < half else 0)
        y0 = cy - (1 if yi * inv_cell - cy < half else 0)
        z0 = cz - (1 if zi * inv_cell - cz < half else 0)
        # A point of another cell hashed into a scanned bucket is out of reach (everything in
        # reach lies in the block), so only a bucket scanned twice could list a point twice:
        # the cell test is needed only when two of the four rows' buckets meet (rare)
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
                        begin, end = bucket_start[b], bucket_start[b + 1 if wraps else b + 2]
                    else:
                        begin, end = bucket_start[0], bucket_start[1]
                    for k in range(begin, end):
                        if check:
                            tx = sorted_cell[k, 0]
                            if (tx != x0 and tx != x0 + 1) or sorted_cell[k, 1] != ty or sorted_cell[k, 2] != tz:
                                continue
                        j = order[k]
                        distance = only_distance if one_segment else segment_distance[point_segment[j]]
                        reach = distance + skin
                        ex = xi - sorted_points[k, 0]
                        ey = yi - sorted_points[k, 1]
                        ez = zi - sorted_points[k, 2]
                        if j == i or distance == zero or not ex * ex + ey * ey + ez * ez < reach * reach:
                            continue
                        if j < own:
                            rx = rest[i, 0] - rest[j, 0]
                            ry = rest[i, 1] - rest[j, 1]
                            rz = rest[i, 2] - rest[j, 2]
                            if rx * rx + ry * ry + rz * rz < distance * distance:
                                continue
                        if p == capacity:
                            return i
                        pairs[p] = j
                        p += 1
        start = row_start[i]
        if p - start > 24:
            pairs[start:p].sort()
        else:  # rows are short: insertion sort
            for a in range(start + 1, p):
                value = pairs[a]
                b = a
                while b > start and pairs[b - 1] > value:
                    pairs[b] = pairs[b - 1]
                    b -= 1
                pairs[b] = value
        split = start
        while split < p and pairs[split] < i:
            split += 1
        row_split[i] = split
        row_start[i + 1] = p
    return own


@kernel
def _refresh_list(
    points, anchor, skin, inv_cell, bucket_start, order, sorted_points, sorted_cell, rest, point_segment,
    segment_distance, row_start, row_split, pairs, list_state,
):
    """Rebuild the list from the current points when ``list_state[0]`` says it is incomplete
    or a point moved more than REBUILD_FRACTION * skin since its build; returns (the row
    after the last one listed, whether it rebuilt). list_state i64 (2,): 1 when the list
    holds every row built from ``anchor``; the entries all rows needed at the last build."""
    own = row_start.shape[0] - 1
    if list_state[0] == 1 and not _displaced(points, anchor, REBUILD_FRACTION * skin):
        return own, False
    for i in range(points.shape[0]):
        for d in range(4):
            anchor[i, d] = points[i, d]
    build_grid(points, inv_cell, bucket_start, order, sorted_points, sorted_cell)
    end = _list_rows(
        0, points, inv_cell, skin, bucket_start, order, sorted_points, sorted_cell, rest, point_segment,
        segment_distance, own, row_start, row_split, pairs,
    )
    list_state[0] = 1 if end == own else 0
    list_state[1] = row_start[end]
    return end, True


@kernel
def _next_rows(
    first, points, inv_cell, skin, bucket_start, order, sorted_points, sorted_cell, rest, point_segment,
    segment_distance, row_start, row_split, pairs, list_state,
):
    """The next chunk of rows of a list that does not fit at once (rows from ``first``, from
    the start of ``pairs``); returns the row after its last; counts the entries."""
    own = row_start.shape[0] - 1
    end = _list_rows(
        first, points, inv_cell, skin, bucket_start, order, sorted_points, sorted_cell, rest, point_segment,
        segment_distance, own, row_start, row_split, pairs,
    )
    if end == first:
        raise ValueError("self-collision: the pair buffer must hold at least one entry per point")
    list_state[1] += row_start[end]
    return end


@kernel
def _pair_sums(first, end, points, row_start, row_split, pairs, point_segment, segment_distance, sums):
    """Rows first..end-1, each pair once: adds each pair's two shares (c_ij weighted by the
    penetration, and the penetration) to sums[i] and, for an own j, sums[j]."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    own = row_start.shape[0] - 1
    one_segment = segment_distance.shape[0] == 1
    only_distance = segment_distance[0] if one_segment else zero
    for i in range(first, end):
        xi = points[i, 0]
        yi = points[i, 1]
        zi = points[i, 2]
        wi = points[i, 3]
        for e in range(row_split[i], row_start[i + 1]):
            j = pairs[e]
            distance = only_distance if one_segment else segment_distance[point_segment[j]]
            ex = xi - points[j, 0]
            ey = yi - points[j, 1]
            ez = zi - points[j, 2]
            d2 = ex * ex + ey * ey + ez * ez
            if not (d2 < distance * distance and d2 > zero):
                continue
            d = np.sqrt(d2)
            depth = distance - d
            push = depth * (distance / d - one)
            wj = points[j, 3]
            factor = push * wi / (wi + wj)
            sums[i, 0] += ex * factor
            sums[i, 1] += ey * factor
            sums[i, 2] += ez * factor
            sums[i, 3] += depth
            if j < own:
                factor = push * wj / (wj + wi)
                sums[j, 0] += (-ex) * factor
                sums[j, 1] += (-ey) * factor
                sums[j, 2] += (-ez) * factor
                sums[j, 3] += depth


@kernel(parallel=True)
def _gather_rows(first, end, points, row_start, pairs, point_segment, segment_distance, stiffness, cur):
    """Rows first..end-1 on all cores, each on its own: i's terms over its whole row (the
    operations of _pair_sums, in the same order), then i moves."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    one_segment = segment_distance.shape[0] == 1
    only_distance = segment_distance[0] if one_segment else zero
    for i in numba.prange(first, end):
        wi = points[i, 3]
        if wi == zero:
            continue
        xi = points[i, 0]
        yi = points[i, 1]
        zi = points[i, 2]
        sx = zero
        sy = zero
        sz = zero
        weight = zero
        for e in range(row_start[i], row_start[i + 1]):
            j = pairs[e]
            distance = only_distance if one_segment else segment_distance[point_segment[j]]
            ex = xi - points[j, 0]
            ey = yi - points[j, 1]
            ez = zi - points[j, 2]
            d2 = ex * ex + ey * ey + ez * ez
            if not (d2 < distance * distance and d2 > zero):
                continue
            d = np.sqrt(d2)
            depth = distance - d
            push = depth * (distance / d - one)
            factor = push * wi / (wi + points[j, 3])
            sx += ex * factor
            sy += ey * factor
            sz += ez * factor
            weight += depth
        if weight > zero:
            scale = stiffness / weight
            cur[i, 0] += sx * scale
            cur[i, 1] += sy * scale
            cur[i, 2] += sz * scale


@kernel
def collide_points(
    points, anchor, skin, inv_cell, bucket_start, order, sorted_points, sorted_cell, rest, point_segment,
    segment_distance, stiffness, row_start, row_split, pairs, list_state, sums, cur,
):
    """Push each own particle i < cur.shape[0] away from the points closer than their
    segment's distance (see the module docstring), each pair once; returns whether the
    neighbour list was rebuilt.

    Reads ``points`` (m,4); keeps the list in anchor (m,4, the points it was built from), the
    grid (bucket_start, order, sorted_points, sorted_cell; cells 1/inv_cell at least twice
    the largest distance + skin), row_start i32 (own+1,), row_split i32 (own,), pairs i32
    (capacity >= m,) and list_state; sums (own,4) of the points' dtype is scratch; updates
    ``cur``.
    """
    zero = np.float32(0.0)
    own = cur.shape[0]
    end, rebuilt = _refresh_list(
        points, anchor, skin, inv_cell, bucket_start, order, sorted_points, sorted_cell, rest, point_segment,
        segment_distance, row_start, row_split, pairs, list_state,
    )
    for i in range(own):
        for d in range(4):
            sums[i, d] = zero
    first = 0
    while True:
        _pair_sums(first, end, points, row_start, row_split, pairs, point_segment, segment_distance, sums)
        if end == own:
            break
        first = end
        end = _next_rows(
            first, points, inv_cell, skin, bucket_start, order, sorted_points, sorted_cell, rest, point_segment,
            segment_distance, row_start, row_split, pairs, list_state,
        )
    for i in range(own):
        weight = sums[i, 3]
        if points[i, 3] != zero and weight > zero:
            scale = stiffness / weight
            cur[i, 0] += sums[i, 0] * scale
            cur[i, 1] += sums[i, 1] * scale
            cur[i, 2] += sums[i, 2] * scale
    return rebuilt


@kernel
def collide_points_parallel(
    points, anchor, skin, inv_cell, bucket_start, order, sorted_points, sorted_cell, rest, point_segment,
    segment_distance, stiffness, row_start, row_split, pairs, list_state, sums, cur,
):
    """collide_points with the rows on all cores (the same bits; ``sums`` is unused)."""
    own = cur.shape[0]
    end, rebuilt = _refresh_list(
        points, anchor, skin, inv_cell, bucket_start, order, sorted_points, sorted_cell, rest, point_segment,
        segment_distance, row_start, row_split, pairs, list_state,
    )
    first = 0
    while True:
        _gather_rows(first, end, points, row_start, pairs, point_segment, segment_distance, stiffness, cur)
        if end == own:
            break
        first = end
        end = _next_rows(
            first, points, inv_cell, skin, bucket_start, order, sorted_points, sorted_cell, rest, point_segment,
            segment_distance, row_start, row_split, pairs, list_state,
        )
    return rebuilt
