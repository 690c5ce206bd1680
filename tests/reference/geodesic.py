"""Reference for clothtool.cook.geodesic: the label propagation in plain Python.

The same functions as the kernel module, run by the interpreter instead of numba (Python
ints and floats, a heapq of Python tuples), so a comparison catches what compilation changes:
typing, integer and float semantics, inlining. Whether the propagation is right is tested
separately, against closed forms (tests/unit/test_geodesic.py).
"""

from __future__ import annotations

import heapq

import numpy as np

# Relative slack of the comparisons: a candidate equal to the current value within this is a
# tie (ties keep the path that bends least, i.e. the smaller sigma), and a straight segment may
# pass outside its edge by this times the distance it has travelled (a path along the edge
# itself, or through a vertex on a shadow line, is then straight). Rest
# positions are float32: a row of vertices on a straight line is straight only to ~1e-7, and
# a slack below that would make a path along such a row bend at every vertex instead of being
# one straight segment (measured: 3-16% long on the bundled skirt with 1e-10).
_SLACK = 1e-6
_ANGLE_SLACK = 1e-4  # radians

# Label slots per vertex: its shortest label plus the fronts of nearby bend vertices that pass
# it (an edge half in the shadow of a corner needs the corner's front on both its ends).
LABELS_PER_VERTEX = 4


def geodesic_from_sources(
    pos, triangles, vertex_triangle_offsets, vertex_triangles, sources, can_bend, labels, max_updates
):
    """Distances from ``sources`` (see the module docstring).

    Args:
        pos: f64 (n,3) vertex positions.
        triangles: i64 (t,3).
        vertex_triangle_offsets, vertex_triangles: i64 CSR, the triangles around each vertex.
        sources: i64 (s,) source vertices (distance 0, their own root).
        can_bend: bool (n,) vertices a shortest path may bend around (sources, reflex boundary
            vertices, saddles): their straight fronts are kept as extra labels.
        labels: label slots per vertex.
        max_updates: give up after this many label pops.

    Returns (dist f64 (n,), inf where unreachable; root i64 (n,), -1 where unreachable;
    done bool: False if ``max_updates`` ran out, and the result is then incomplete).
    """
    n = pos.shape[0]
    lab_pseudo = np.full((n, labels), -1, np.int64)
    lab_dist = np.full((n, labels), np.inf)
    lab_sigma = np.zeros((n, labels))
    lab_root = np.full((n, labels), -1, np.int64)
    lab_block = np.full((n, labels), -1, np.int64)  # -1: a path; b: a shadow label behind bend vertex b
    heap = [(0.0, np.int64(0), np.int64(0))]
    heap.pop()
    for s in sources:
        lab_pseudo[s, 0] = s
        lab_dist[s, 0] = 0.0
        lab_root[s, 0] = s
        heapq.heappush(heap, (0.0, np.int64(s), np.int64(s)))
    labs = (lab_pseudo, lab_dist, lab_sigma, lab_root, lab_block)
    updates = 0
    done = True
    while len(heap) > 0:
        d, v, p = heapq.heappop(heap)
        slot = _slot_of(lab_pseudo, v, p)
        if slot < 0 or lab_dist[v, slot] != d:
            continue  # a stale entry: the label changed or was evicted since
        updates += 1
        if updates > max_updates:
            done = False
            break
        sigma = lab_sigma[v, slot]
        root = lab_root[v, slot]
        block = lab_block[v, slot]
        shortest = block < 0 and d <= _shortest(lab_dist, lab_block, v)
        for k in range(vertex_triangle_offsets[v], vertex_triangle_offsets[v + 1]):
            t = vertex_triangles[k]
            at = _corner_of(triangles, t, v)
            for corner in range(3):
                if corner == at:
                    continue
                u = triangles[t, corner]
                c = triangles[t, 3 - corner - at]
                if shortest:
                    # the path bends at v, then runs straight along the edge v -> u
                    cand = d + np.sqrt(_distance_sq(pos, v, u))
                    _offer(heap, labs, can_bend, u, cand, v, d, root, -1)
                # straight on from p across the edge (v, u) to c, if u has p's front too
                j = _slot_of(lab_pseudo, u, p)
                if j < 0 or lab_sigma[u, j] != sigma:
                    continue
                ok, length, cx, cy, sx, sy = _frame(pos, v, u, c, d - sigma, lab_dist[u, j] - sigma)
                if not ok:
                    continue
                x = _crossing(sx, sy, cx, cy)
                # float32 rest positions put a crossing off by ~1e-7 of the distance travelled
                slack = _SLACK * (length + d - sigma)
                inside = -slack <= x <= length + slack
                cand = sigma + np.hypot(cx - sx, cy - sy)
                u_block = lab_block[u, j]
                if block < 0 and u_block < 0:
                    if inside:
                        _offer(heap, labs, can_bend, c, cand, p, sigma, root, -1)
                        continue
                    # past a bend vertex at an end of the edge the front goes on in its shadow
                    if x < 0.0 and can_bend[v]:
                        _offer(heap, labs, can_bend, c, cand, p, sigma, root, v)
                    elif x > length and can_bend[u]:
                        _offer(heap, labs, can_bend, c, cand, p, sigma, root, u)
                    # c is outside the beam through (v, u) on u's side (x > length) or v's: the
                    # beam leaves the triangle through the edge from the other end to c
                    _look_beyond(
                        heap, labs, can_bend, pos, triangles, vertex_triangle_offsets, vertex_triangles,
                        t, u if x < 0.0 else v, c, x < 0.0, length, cx, cy, sx, sy, p, sigma, root, slack,
                    )
                elif inside:
                    # one end (or both) in the shadow of bend vertex b: c is lit if the segment
                    # crosses the edge between the lit end and the shadow line through b
                    b = block if block >= 0 else u_block
                    lit = -1.0
                    if block < 0 or u_block < 0:
                        lit = 0.0 if block < 0 else length
                    shadow = _shadow_crossing(pos, labs, v, u, c, b, sx, sy)
                    if lit >= 0.0 and np.isfinite(shadow) and min(lit, shadow) - slack <= x <= max(lit, shadow) + slack:
                        _offer(heap, labs, can_bend, c, cand, p, sigma, root, -1)
                    elif block < 0 or u_block < 0 or block == u_block:
                        _offer(heap, labs, can_bend, c, cand, p, sigma, root, b)
    dist = np.full(n, np.inf)
    best_root = np.full(n, -1, np.int64)
    for v in range(n):
        best = -1
        for j in range(labels):
            if lab_pseudo[v, j] >= 0 and lab_block[v, j] < 0 and (
                best < 0
                or lab_dist[v, j] < lab_dist[v, best]
                or (lab_dist[v, j] == lab_dist[v, best] and lab_sigma[v, j] < lab_sigma[v, best])
            ):
                best = j
        if best >= 0:
            dist[v] = lab_dist[v, best]
            best_root[v] = lab_root[v, best]
    return dist, best_root, done


def _slot_of(lab_pseudo, v, p):
    """The slot of ``v`` holding pseudo-source ``p``'s label, or -1."""
    for j in range(lab_pseudo.shape[1]):
        if lab_pseudo[v, j] == p:
            return j
    return -1


def _shortest(lab_dist, lab_block, v):
    """``v``'s shortest path label (shadow labels are no paths)."""
    best = np.inf
    for j in range(lab_dist.shape[1]):
        if lab_block[v, j] < 0:
            best = min(best, lab_dist[v, j])
    return best


def _offer(heap, labs, can_bend, c, cand, p, sigma, root, block):
    """Offer vertex ``c`` the label (pseudo-source ``p``, its ``sigma``, length ``cand``,
    ``block`` -1 for a path or the bend vertex whose shadow it lies in).

    A label of ``p`` already at ``c`` is replaced if shorter (or as long and bending less);
    a path replaces a shadow label of the same front. A new label takes an empty slot, else
    evicts (in order) a shadow label, a label of a vertex that cannot bend a path and is not
    ``c``'s shortest, or a longer label. Labels of vertices that cannot bend a path are only
    taken as ``c``'s new shortest: they keep every vertex reachable (and exact values flowing
    past obtuse triangles) without crowding out real fronts. Shadow labels only take an empty
    slot or a longer shadow label's.
    """
    lab_pseudo, lab_dist, lab_sigma, lab_root, lab_block = labs
    j = _slot_of(lab_pseudo, c, p)
    if j >= 0:
        old = lab_dist[c, j]
        if block >= 0 and lab_block[c, j] < 0:
            return
        take = cand < old * (1.0 - _SLACK) or (
            cand <= old * (1.0 + _SLACK) and (sigma < lab_sigma[c, j] * (1.0 - _SLACK) or (block < 0 <= lab_block[c, j]))
        )
        if take:
            _store(heap, labs, c, j, cand, p, sigma, root, block)
        return
    best = _shortest(lab_dist, lab_block, c)
    if not can_bend[p] and not (block < 0 and cand < best * (1.0 - _SLACK)):
        return
    empty = -1
    shadow = -1
    plain = -1
    longest = -1
    for k in range(lab_pseudo.shape[1]):
        q = lab_pseudo[c, k]
        if q < 0:
            empty = k
            break
        if lab_block[c, k] >= 0:
            if shadow < 0 or lab_dist[c, k] > lab_dist[c, shadow]:
                shadow = k
        elif not can_bend[q] and lab_dist[c, k] > best:
            if plain < 0 or lab_dist[c, k] > lab_dist[c, plain]:
                plain = k
        if longest < 0 or lab_dist[c, k] > lab_dist[c, longest]:
            longest = k
    if empty >= 0:
        _store(heap, labs, c, empty, cand, p, sigma, root, block)
    elif block >= 0:
        if shadow >= 0 and cand < lab_dist[c, shadow]:
            _store(heap, labs, c, shadow, cand, p, sigma, root, block)
    elif shadow >= 0:
        _store(heap, labs, c, shadow, cand, p, sigma, root, block)
    elif plain >= 0 and can_bend[p]:
        _store(heap, labs, c, plain, cand, p, sigma, root, block)
    elif cand < lab_dist[c, longest]:
        _store(heap, labs, c, longest, cand, p, sigma, root, block)


def _store(heap, labs, c, j, cand, p, sigma, root, block):
    lab_pseudo, lab_dist, lab_sigma, lab_root, lab_block = labs
    lab_pseudo[c, j] = p
    lab_dist[c, j] = cand
    lab_sigma[c, j] = sigma
    lab_root[c, j] = root
    lab_block[c, j] = block
    heapq.heappush(heap, (cand, np.int64(c), np.int64(p)))


def _front_radius(labs, x, b):
    """(distance from bend vertex ``b`` to vertex ``x`` along b's straight front, b's sigma),
    or (inf, 0) if x has no such path label."""
    lab_pseudo, lab_dist, lab_sigma, lab_root, lab_block = labs
    if x == b:
        return 0.0, _shortest(lab_dist, lab_block, b)
    j = _slot_of(lab_pseudo, x, b)
    if j < 0 or lab_block[x, j] >= 0:
        return np.inf, 0.0
    return lab_dist[x, j] - lab_sigma[x, j], lab_sigma[x, j]


def _shadow_crossing(pos, labs, v, u, c, b, sx, sy):
    """Where the shadow line of bend vertex ``b`` (the ray from the front's source S through
    b) crosses the line of the edge (v, u), in ``_frame``'s coordinates; b is placed by its
    own front's labels at v and u. inf if they are missing or the ray never gets there."""
    rv, sigma_v = _front_radius(labs, v, b)
    ru, sigma_u = _front_radius(labs, u, b)
    if not (np.isfinite(rv) and np.isfinite(ru)) or sigma_v != sigma_u:
        return np.inf
    ok, length, cx, cy, bx, by = _frame(pos, v, u, c, rv, ru)
    if not ok or by <= sy:
        return np.inf
    return sx + (bx - sx) * (-sy) / (by - sy)


def _crossing(sx, sy, px, py):
    """x where the segment from S (below the x axis) to P (above it) crosses the axis."""
    return sx + (px - sx) * (-sy) / (py - sy)


def _look_beyond(
    heap, labs, can_bend, pos, triangles, vertex_triangle_offsets, vertex_triangles,
    t, a, c, a_is_u, length, cx, cy, sx, sy, p, sigma, root, slack,
):
    """The segment from S to c misses the edge (v, u) of triangle ``t``, but one to the vertex
    beyond the edge (a, c) may cross both edges (v, u) and (a, c): that vertex is then reached
    straight through them (next to a shadow line an edge may be lit only in part, and its
    other end, in the shadow, has no label of the front to trilaterate from)."""
    ax = length if a_is_u else 0.0
    t2 = _across(triangles, vertex_triangle_offsets, vertex_triangles, t, a, c)
    if t2 < 0:
        return
    e = triangles[t2, 3 - _corner_of(triangles, t2, a) - _corner_of(triangles, t2, c)]
    ok, ex, ey = _place_beyond(pos, a, c, e, ax, cx, cy, length - ax)
    if not ok or ey <= 0.0:
        return
    x = _crossing(sx, sy, ex, ey)
    if -slack <= x <= length + slack and _crosses(sx, sy, ex, ey, ax, 0.0, cx, cy, slack):
        _offer(heap, labs, can_bend, e, sigma + np.hypot(ex - sx, ey - sy), p, sigma, root, -1)


def _corner_of(triangles, t, v):
    """Index (0..2) of vertex ``v`` in triangle ``t``."""
    if triangles[t, 0] == v:
        return 0
    if triangles[t, 1] == v:
        return 1
    return 2


def _distance_sq(pos, a, b):
    dx = pos[b, 0] - pos[a, 0]
    dy = pos[b, 1] - pos[a, 1]
    dz = pos[b, 2] - pos[a, 2]
    return dx * dx + dy * dy + dz * dz


def _frame(pos, v, u, c, rv, ru):
    """Triangle (v, u, c) laid in the plane with v at the origin, u at (length, 0) and c at
    (cx, cy), cy > 0, and the point S at distances ``rv`` from v and ``ru`` from u on the far
    side of the edge. Returns (ok, length, cx, cy, sx, sy); not ok for a degenerate triangle
    or distances that no point has."""
    ex = pos[u, 0] - pos[v, 0]
    ey = pos[u, 1] - pos[v, 1]
    ez = pos[u, 2] - pos[v, 2]
    length = np.sqrt(ex * ex + ey * ey + ez * ez)
    if length == 0.0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0
    wx = pos[c, 0] - pos[v, 0]
    wy = pos[c, 1] - pos[v, 1]
    wz = pos[c, 2] - pos[v, 2]
    cx = (wx * ex + wy * ey + wz * ez) / length
    cy_sq = wx * wx + wy * wy + wz * wz - cx * cx
    if cy_sq <= 0.0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0
    sx = (rv * rv - ru * ru + length * length) / (2.0 * length)
    sy_sq = rv * rv - sx * sx
    if sy_sq < -_SLACK * length * length:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0
    return True, length, cx, np.sqrt(cy_sq), sx, -np.sqrt(max(sy_sq, 0.0))


def _crosses(sx, sy, px, py, ax, ay, bx, by, slack):
    """Does the segment S -> P cross the segment A -> B (within ``slack`` along A -> B)?"""
    dx = px - sx
    dy = py - sy
    fx = bx - ax
    fy = by - ay
    denominator = dx * fy - dy * fx
    if denominator == 0.0:
        return False
    along_sp = ((ax - sx) * fy - (ay - sy) * fx) / denominator
    along_ab = ((ax - sx) * dy - (ay - sy) * dx) / denominator
    margin = slack / np.hypot(fx, fy)
    return 0.0 <= along_sp <= 1.0 and -margin <= along_ab <= 1.0 + margin


def _across(triangles, vertex_triangle_offsets, vertex_triangles, t, a, b):
    """The triangle other than ``t`` on the edge (a, b), or -1 (a boundary edge)."""
    for k in range(vertex_triangle_offsets[a], vertex_triangle_offsets[a + 1]):
        t2 = vertex_triangles[k]
        if t2 != t and (triangles[t2, 0] == b or triangles[t2, 1] == b or triangles[t2, 2] == b):
            return t2
    return -1


def _place_beyond(pos, a, c, e, ax, cx, cy, other_x):
    """Vertex ``e`` unfolded across the edge from A = (ax, 0) to C = (cx, cy) into the frame,
    on the side away from the triangle's third vertex at (other_x, 0). Returns (ok, x, y)."""
    fx = cx - ax
    fy = cy
    edge = np.hypot(fx, fy)
    if edge == 0.0:
        return False, 0.0, 0.0
    fx /= edge
    fy /= edge
    ra_sq = _distance_sq(pos, a, e)
    rc_sq = _distance_sq(pos, c, e)
    along = (ra_sq - rc_sq + edge * edge) / (2.0 * edge)
    across = np.sqrt(max(ra_sq - along * along, 0.0))
    # the normal of A -> C pointing away from the third vertex
    nx = -fy
    ny = fx
    if nx * (other_x - ax) > 0.0:
        nx = -nx
        ny = -ny
    return True, ax + along * fx + across * nx, along * fy + across * ny
