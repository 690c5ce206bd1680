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

Grid (used to build the list): cell size = the list's reach (largest distance + skin), so
that every point within reach of a point lies in the 3 x 3 x 3 cells around its cell. Cells
are numbered row by row and layer by layer, rows as long as the points' cells along x plus
two (``strides``, from the points' bounds at each build), and the number modulo B (a power
of two) is the cell's bucket; the points are counting-sorted by bucket (stable: by index
within a bucket) into contiguous copies. Three cells along x are then one contiguous run of
the sorted points, and the runs a query reads lie at fixed offsets from its own bucket, so
that visiting the points in sorted order reads the grid front to back (a hash spreading the
rows at random made each run a cache miss). A build scans, from each point, half of its
neighbourhood (NvCloth's sweep does the same): the rest of its own cell and the next cell
along x (one run), then the row y + 1 and the three rows of layer z + 1 (four runs of three
cells), finding each pair once; the pairs are then laid out as rows and sorted. A point of
another cell that shares a scanned bucket (when the grid is longer than B) is out of reach,
so cells are compared only when two runs of a query share a bucket, which depends on the
strides and B alone (``_runs_overlap``). Cost O(m + B) to sort, O(m) to query for a bounded
number of points per cell.

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
from clothtool._minmax import largest, smallest

CELL_LIMIT = np.float32(1.0e9)  # cell coordinates are clamped to +-this (and NaN maps to -it)
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
def _bucket(cx, cy, cz, strides, mask):
    """Cell (cx, cy, cz)'s bucket: its index in a grid of rows strides[0] cells long and
    layers of strides[1] cells, modulo the bucket count."""
    return (np.int64(cx) + np.int64(cy) * strides[0] + np.int64(cz) * strides[1]) & mask


@kernel
def build_grid(points, inv_cell, bucket_start, order, sorted_points, sorted_cell, strides):
    """Put points into cells of size 1/inv_cell and counting-sort them by bucket.

    strides i64 (2,): set to the grid's row and layer lengths, the points' cells along x
    (and y) and two more (the cells x - 1 and x + 1 of a query then never stand for a cell
    of the row next to it); bucket_start i32 (B+1,), B a power of two: bucket b holds sorted
    slots bucket_start[b]:bucket_start[b+1]; order i32 (m,): the point in each sorted slot
    (by index within a bucket); sorted_points (m,4) and sorted_cell i32 (m,3): each slot's
    point and cell, so that a bucket's points are contiguous in memory.
    """
    buckets = bucket_start.shape[0] - 1
    mask = np.int64(buckets - 1)
    low_x = np.inf
    high_x = -np.inf
    low_y = np.inf
    high_y = -np.inf
    for i in range(points.shape[0]):  # NaN takes no part (its cell is -CELL_LIMIT anyway)
        low_x = smallest(low_x, points[i, 0])
        high_x = largest(high_x, points[i, 0])
        low_y = smallest(low_y, points[i, 1])
        high_y = largest(high_y, points[i, 1])
    if points.shape[0] == 0 or not low_x <= high_x or not low_y <= high_y:
        strides[0] = 3
        strides[1] = 9
    else:
        width = np.int64(_cell_coordinate(high_x, inv_cell)) - np.int64(_cell_coordinate(low_x, inv_cell)) + 3
        height = np.int64(_cell_coordinate(high_y, inv_cell)) - np.int64(_cell_coordinate(low_y, inv_cell)) + 3
        strides[0] = width
        strides[1] = width * height
    for b in range(bucket_start.shape[0]):
        bucket_start[b] = 0
    for i in range(points.shape[0]):
        cx = _cell_coordinate(points[i, 0], inv_cell)
        cy = _cell_coordinate(points[i, 1], inv_cell)
        cz = _cell_coordinate(points[i, 2], inv_cell)
        bucket_start[_bucket(cx, cy, cz, strides, mask) + 1] += 1
    for b in range(buckets):
        bucket_start[b + 1] += bucket_start[b]
    # scatter with bucket_start[b] as bucket b's cursor, then shift the ends back to starts
    for i in range(points.shape[0]):
        cx = _cell_coordinate(points[i, 0], inv_cell)
        cy = _cell_coordinate(points[i, 1], inv_cell)
        cz = _cell_coordinate(points[i, 2], inv_cell)
        b = _bucket(cx, cy, cz, strides, mask)
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
    over = 0
    for i in range(points.shape[0]):  # no early exit: the loop vectorises
        dx = points[i, 0] - anchor[i, 0]
        dy = points[i, 1] - anchor[i, 1]
        dz = points[i, 2] - anchor[i, 2]
        over += not dx * dx + dy * dy + dz * dz <= limit2
    return over > 0


@kernel
def _runs_overlap(strides, mask):
    """Whether two of the nine runs of a query share a bucket (B = mask + 1 buckets): run
    (dy, dz) holds the buckets of cells x - 1, x, x + 1 of row (y + dy, z + dz), i.e. three
    consecutive buckets from an offset dy strides[0] + dz strides[1] that does not depend on
    the cell queried. Fewer than 8 buckets count as shared."""
    if mask < 8:
        return True
    for a in range(9):
        offset_a = (np.int64(a % 3 - 1) * strides[0] + np.int64(a // 3 - 1) * strides[1]) & mask
        for b in range(a + 1, 9):
            offset_b = (np.int64(b % 3 - 1) * strides[0] + np.int64(b // 3 - 1) * strides[1]) & mask
            gap = (offset_a - offset_b) & mask
            if gap <= 2 or gap >= mask - 1:
                return True
    return False


@kernel(inline="always")
def _close_at_rest(i, j, rest, distance):
    """Whether own particles i and j were closer than ``distance`` in the rest pose (NvCloth's
    rest filter: such neighbours are not fought over)."""
    rx = rest[i, 0] - rest[j, 0]
    ry = rest[i, 1] - rest[j, 1]
    rz = rest[i, 2] - rest[j, 2]
    return rx * rx + ry * ry + rz * rz < distance * distance


@kernel
def _sort_rows(first, end, row_start, row_split, pairs):
    """Sorts rows first..end-1 of the list ascending and sets their row_split."""
    for i in range(first, end):
        start = row_start[i]
        stop = row_start[i + 1]
        if stop - start > 24:
            pairs[start:stop].sort()
        else:  # rows are short: insertion sort
            for a in range(start + 1, stop):
                value = pairs[a]
                b = a
                while b > start and pairs[b - 1] > value:
                    pairs[b] = pairs[b - 1]
                    b -= 1
                pairs[b] = value
        split = start
        while split < stop and pairs[split] < i:
            split += 1
        row_split[i] = split


@kernel
def _list_pairs(
    skin, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment, segment_distance, row_start,
    row_split, pairs, found,
):
    """The whole list at once, each pair found once (NvCloth's half neighbourhood): from each
    grid slot, its own cell's later slots, the next cell along x, and the nine cells of the
    rows y + 1 (same z) and z + 1 (x and y - 1..y + 1); a pair between two cells is found from
    the lower one (by z, then y, then x). The found pairs (found (capacity, 2)) are then
    laid out as rows, both ways for two own particles, and sorted. Returns the entries the
    list needs: when that exceeds the capacity of ``pairs`` (or of ``found``), the list is
    left unfinished and _list_rows must build it a chunk at a time.

    Cells must be at least the largest distance + skin: everything within reach of a point
    is then in the 3 x 3 x 3 cells around its cell."""
    zero = np.float32(0.0)
    mask = np.int64(bucket_start.shape[0] - 2)
    own = row_start.shape[0] - 1
    one_segment = segment_distance.shape[0] == 1  # a cloth alone: one distance for every pair
    only_distance = segment_distance[0] if one_segment else zero
    check = _runs_overlap(strides, mask)
    row = strides[0]
    layer = strides[1]
    widest = zero
    for segment in range(segment_distance.shape[0]):
        widest = largest(widest, segment_distance[segment])
    widest2 = (widest + skin) * (widest + skin)  # no pair's reach is larger (rounding is monotone)
    capacity = smallest(pairs.shape[0], found.shape[0])
    for i in range(own + 1):
        row_start[i] = 0
    entries = 0
    count = 0
    for slot in range(sorted_points.shape[0]):
        a = order[slot]
        xa = sorted_points[slot, 0]
        ya = sorted_points[slot, 1]
        za = sorted_points[slot, 2]
        x0 = np.int64(sorted_cell[slot, 0])
        y0 = np.int64(sorted_cell[slot, 1])
        z0 = np.int64(sorted_cell[slot, 2])
        base = x0 + y0 * row + z0 * layer  # this cell's number (its bucket, unmasked)
        for run in range(5):
            # run 0: this cell after this slot, then cell x0 + 1; runs 1-4: cells x0 - 1..x0 + 1
            # of rows (y0 + 1, z0), (y0 - 1, z0 + 1), (y0, z0 + 1), (y0 + 1, z0 + 1)
            dy = 0 if run == 0 else (1 if run == 1 else run - 3)
            dz = 1 if run >= 2 else 0
            dx = 0 if run == 0 else -1
            b = (base + dx + dy * row + dz * layer) & mask
            cells = 2 if run == 0 else 3
            split = check or b + cells - 1 > mask  # cell by cell (shared or wrapping buckets)
            for part in range(cells if split else 1):
                if split:
                    bucket = (b + part) & mask
                    begin = bucket_start[bucket]
                    end = bucket_start[bucket + 1]
                else:
                    begin = bucket_start[b]
                    end = bucket_start[b + cells]
                if run == 0 and part == 0:
                    begin = slot + 1
                tx = x0 + dx + part
                ty = y0 + dy
                tz = z0 + dz
                for k in range(begin, end):
                    ex = xa - sorted_points[k, 0]  # the sign does not matter: only |e| does
                    ey = ya - sorted_points[k, 1]
                    ez = za - sorted_points[k, 2]
                    d2 = ex * ex + ey * ey + ez * ez
                    if not d2 < widest2:  # most candidates: out of every segment's reach
                        continue
                    if check and (sorted_cell[k, 0] != tx or sorted_cell[k, 1] != ty or sorted_cell[k, 2] != tz):
                        continue
                    c = order[k]
                    if a >= own and c >= own:
                        continue  # two neighbour points: no row wants them
                    # the test of _list_rows, written out
                    i, j = (a, c) if a < own else (c, a)
                    distance = only_distance if one_segment else segment_distance[point_segment[j]]
                    reach = distance + skin
                    if distance == zero or not d2 < reach * reach:
                        continue
                    if j < own and _close_at_rest(i, j, rest, distance):
                        continue
                    entries += 2 if j < own else 1
                    if entries <= capacity:
                        found[count, 0] = i
                        found[count, 1] = j
                        count += 1
                        row_start[i + 1] += 1
                        if j < own:
                            row_start[j + 1] += 1
    if entries > capacity:
        return entries
    for i in range(own):
        row_start[i + 1] += row_start[i]
        row_split[i] = row_start[i]  # each row's cursor while filling
    for f in range(count):
        i = found[f, 0]
        j = found[f, 1]
        pairs[row_split[i]] = j
        row_split[i] += 1
        if j < own:
            pairs[row_split[j]] = i
            row_split[j] += 1
    _sort_rows(0, own, row_start, row_split, pairs)
    return entries


@kernel
def _list_rows(
    first, points, inv_cell, skin, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment,
    segment_distance, row_start, row_split, pairs,
):
    """List rows first, first + 1, ... into ``pairs`` from its start while they fit; returns
    the row after the last one listed (own = row_start.shape[0] - 1 when all did).

    Row i holds pairs[row_start[i]:row_start[i + 1]], ascending, the points of the grid (built
    from ``points``) within their distance + skin of point i, less i itself, points whose
    segment keeps no distance and own particles closer than the distance at rest;
    row_split[i] is the first entry above i. Each row is a query of the 3 x 3 x 3 cells
    around i's (9 runs of 3 cells); cells must be at least the largest distance + skin."""
    zero = np.float32(0.0)
    mask = np.int64(bucket_start.shape[0] - 2)
    own = row_start.shape[0] - 1
    one_segment = segment_distance.shape[0] == 1
    only_distance = segment_distance[0] if one_segment else zero
    check = _runs_overlap(strides, mask)
    capacity = pairs.shape[0]
    p = 0
    for i in range(first, own):
        row_start[i] = p
        xi = points[i, 0]
        yi = points[i, 1]
        zi = points[i, 2]
        x0 = _cell_coordinate(xi, inv_cell) - 1
        cy = _cell_coordinate(yi, inv_cell)
        cz = _cell_coordinate(zi, inv_cell)
        for tz in range(cz - 1, cz + 2):
            for ty in range(cy - 1, cy + 2):
                b = _bucket(x0, ty, tz, strides, mask)
                split = check or b + 2 > mask  # cell by cell (shared or wrapping buckets)
                for part in range(3 if split else 1):
                    bucket = (b + part) & mask
                    end = bucket_start[bucket + 1] if split else bucket_start[b + 3]
                    for k in range(bucket_start[bucket], end):
                        if check and (sorted_cell[k, 0] != x0 + part or sorted_cell[k, 1] != ty or sorted_cell[k, 2] != tz):
                            continue
                        j = order[k]
                        # the distance of j's segment: a pair of segments with no distance is
                        # never listed, nor are own particles closer than it at rest
                        distance = only_distance if one_segment else segment_distance[point_segment[j]]
                        reach = distance + skin
                        ex = xi - sorted_points[k, 0]
                        ey = yi - sorted_points[k, 1]
                        ez = zi - sorted_points[k, 2]
                        if j == i or distance == zero or not ex * ex + ey * ey + ez * ez < reach * reach:
                            continue
                        if j < own and _close_at_rest(i, j, rest, distance):
                            continue
                        if p == capacity:
                            return i
                        pairs[p] = j
                        p += 1
        row_start[i + 1] = p
        _sort_rows(i, i + 1, row_start, row_split, pairs)
    return own


@kernel
def _refresh_list(
    points, anchor, skin, inv_cell, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment,
    segment_distance, row_start, row_split, pairs, found, list_state,
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
    build_grid(points, inv_cell, bucket_start, order, sorted_points, sorted_cell, strides)
    entries = _list_pairs(
        skin, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment, segment_distance, row_start,
        row_split, pairs, found,
    )
    list_state[1] = entries
    if entries <= pairs.shape[0] and entries <= found.shape[0]:
        list_state[0] = 1
        return own, True
    list_state[0] = 0  # too big: a chunk of rows at a time, until the stage grows the buffers
    end = _list_rows(
        0, points, inv_cell, skin, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment,
        segment_distance, row_start, row_split, pairs,
    )
    return end, True


@kernel
def _next_rows(
    first, points, inv_cell, skin, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment,
    segment_distance, row_start, row_split, pairs,
):
    """The next chunk of rows of a list that does not fit at once (rows from ``first``, from
    the start of ``pairs``); returns the row after its last."""
    end = _list_rows(
        first, points, inv_cell, skin, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment,
        segment_distance, row_start, row_split, pairs,
    )
    if end == first:
        raise ValueError("self-collision: the pair buffer must hold at least one entry per point")
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
            wj = points[j, 3]
            if wi + wj == zero:
                continue  # two pinned particles: neither moves
            d = np.sqrt(d2)
            depth = distance - d
            push = depth * (distance / d - one)
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
    points, anchor, skin, inv_cell, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment,
    segment_distance, stiffness, row_start, row_split, pairs, found, list_state, sums, cur,
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
        points, anchor, skin, inv_cell, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment,
        segment_distance, row_start, row_split, pairs, found, list_state,
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
            first, points, inv_cell, skin, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment,
            segment_distance, row_start, row_split, pairs,
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
    points, anchor, skin, inv_cell, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment,
    segment_distance, stiffness, row_start, row_split, pairs, found, list_state, sums, cur,
):
    """collide_points with the rows on all cores (the same bits; ``sums`` is unused)."""
    own = cur.shape[0]
    end, rebuilt = _refresh_list(
        points, anchor, skin, inv_cell, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment,
        segment_distance, row_start, row_split, pairs, found, list_state,
    )
    first = 0
    while True:
        _gather_rows(first, end, points, row_start, pairs, point_segment, segment_distance, stiffness, cur)
        if end == own:
            break
        first = end
        end = _next_rows(
            first, points, inv_cell, skin, bucket_start, order, sorted_points, sorted_cell, strides, rest, point_segment,
            segment_distance, row_start, row_split, pairs,
        )
    return rebuilt
