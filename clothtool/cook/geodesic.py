"""Geodesic distance over a triangle mesh from a set of source vertices, by unfolding.

Why not a library: measured on flat grids against closed forms (benchmarks/tethers.py), the
candidates on PyPI were each missing something. The shortest path over the edge graph (scipy's
dijkstra, what the cook used before) is 5-8% long for directions between the edges; the heat
method (potpourri3d) is 2% long on average and 40% off at worst, fast marching (potpourri3d)
4% off near a point source at any resolution; exact MMP (pygeodesic) is exact but took 25 s
for one pinned corner of a 256^2 grid; gdist does not load with numpy 2.

The method here is Dijkstra's ordering with the fast-marching triangle update (as in
Novotni & Klein's and Surazhsky et al.'s virtual-source propagation, one source a vertex):
every vertex carries the distance, the *pseudo-source* its straight path starts from (a
source vertex, or a vertex the path bends around, such as the inner corner of an L) and that
pseudo-source's own distance ``sigma``. A vertex ``c`` gets a candidate from

* an edge ``v -> c``: ``d[v] + |vc|``, a path bending at ``v`` (``v`` becomes the pseudo-source);
* a triangle ``(v, u, c)`` whose ``v`` and ``u`` share a pseudo-source: the source is placed in
  the triangle's plane from its distances to ``v`` and ``u`` (two circles meet on the far side
  of ``vu``), and if the segment from it to ``c`` crosses the edge ``vu`` the candidate is
  ``sigma + |Sc|``, a straight line in the unfolded strip.

Every candidate is the length of a path over the surface, so the result never exceeds the edge
graph's distance. On a developable surface (a flat sheet, a cylinder, a cone away from its tip)
that is simply connected the straight segments are exact, so the result is the exact geodesic
up to rounding (tested to 1e-9 on sheets, L-shapes and cylinders). Over curved patches (a
saddle or a cone tip strictly inside the unfolded strip) the unfolding is only locally right
and the result is an approximation, as fast marching is; callers keep it at least the straight
line. Updates are label-correcting (a popped vertex whose value later drops is pushed again),
so obtuse triangles, which break fast marching's causality, are handled; ``max_updates`` bounds
that work on pathological meshes, and the caller falls back to the edge graph if it runs out.

Each vertex also carries ``root``, the source vertex its path starts from: a tether's anchor.
"""

from __future__ import annotations

import heapq

import numpy as np

from clothtool._jit import kernel

# Relative slack of the comparisons: a candidate equal to the current value within this is a
# tie (ties keep the path that bends least, i.e. the smaller sigma), and a straight segment may
# pass this close outside its edge (a path along the edge itself is then straight). Rest
# positions are float32: a row of vertices on a straight line is straight only to ~1e-7, and
# a slack below that would make a path along such a row bend at every vertex instead of being
# one straight segment (measured: 3-16% long on the bundled skirt with 1e-10).
_SLACK = 1e-6


@kernel
def _geodesic_from_sources(pos, triangles, vertex_triangle_offsets, vertex_triangles, sources, max_updates):
    """Distances from ``sources`` (see the module docstring).

    Args:
        pos: f64 (n,3) vertex positions.
        triangles: i64 (t,3).
        vertex_triangle_offsets, vertex_triangles: i64 CSR, the triangles around each vertex.
        sources: i64 (s,) source vertices (distance 0, their own root).
        max_updates: give up after this many vertex pops.

    Returns (dist f64 (n,), inf where unreachable; root i64 (n,), -1 where unreachable;
    done bool: False if ``max_updates`` ran out, and the result is then incomplete).
    """
    n = pos.shape[0]
    dist = np.full(n, np.inf)
    sigma = np.zeros(n)
    pseudo = np.full(n, -1, np.int64)
    root = np.full(n, -1, np.int64)
    heap = [(0.0, np.int64(0))]
    heap.pop()
    for s in sources:
        dist[s] = 0.0
        pseudo[s] = s
        root[s] = s
        heapq.heappush(heap, (0.0, np.int64(s)))
    updates = 0
    while len(heap) > 0:
        d, v = heapq.heappop(heap)
        if d != dist[v]:
            continue  # a stale entry: v's value changed and v was pushed again
        updates += 1
        if updates > max_updates:
            return dist, root, False
        for k in range(vertex_triangle_offsets[v], vertex_triangle_offsets[v + 1]):
            t = vertex_triangles[k]
            for corner in range(3):
                u = triangles[t, corner]
                if u == v:
                    continue
                c = triangles[t, 3 - corner - _corner_of(triangles, t, v)]
                # the path bends at v, then straight along the edge v -> u
                cand = d + np.sqrt(_distance_sq(pos, v, u))
                _relax(heap, dist, sigma, pseudo, root, u, cand, v, d, root[v])
                # straight from v's pseudo-source across the edge (v, u) to c
                if pseudo[u] == pseudo[v] and sigma[u] == sigma[v] and np.isfinite(dist[u]) and c != u:
                    cand = _unfolded(pos, v, u, c, d - sigma[v], dist[u] - sigma[v])
                    if np.isfinite(cand):
                        _relax(heap, dist, sigma, pseudo, root, c, sigma[v] + cand, pseudo[v], sigma[v], root[v])
    return dist, root, True


@kernel(inline="always")
def _corner_of(triangles, t, v):
    """Index (0..2) of vertex ``v`` in triangle ``t``."""
    if triangles[t, 0] == v:
        return 0
    if triangles[t, 1] == v:
        return 1
    return 2


@kernel(inline="always")
def _distance_sq(pos, a, b):
    dx = pos[b, 0] - pos[a, 0]
    dy = pos[b, 1] - pos[a, 1]
    dz = pos[b, 2] - pos[a, 2]
    return dx * dx + dy * dy + dz * dz


@kernel(inline="always")
def _unfolded(pos, v, u, c, rv, ru):
    """Distance to ``c`` from the point at distances ``rv`` from ``v`` and ``ru`` from ``u`` on
    the far side of edge ``vu`` in the plane of triangle (v, u, c); inf if the segment from that
    point to ``c`` misses the edge (the straight path would leave the triangle strip)."""
    # 2D frame: v at the origin, u on the +x axis, c above it
    ex = pos[u, 0] - pos[v, 0]
    ey = pos[u, 1] - pos[v, 1]
    ez = pos[u, 2] - pos[v, 2]
    length = np.sqrt(ex * ex + ey * ey + ez * ez)
    if length == 0.0:
        return np.inf
    cx3 = pos[c, 0] - pos[v, 0]
    cy3 = pos[c, 1] - pos[v, 1]
    cz3 = pos[c, 2] - pos[v, 2]
    cx = (cx3 * ex + cy3 * ey + cz3 * ez) / length
    cy_sq = cx3 * cx3 + cy3 * cy3 + cz3 * cz3 - cx * cx
    if cy_sq <= 0.0:
        return np.inf  # a degenerate triangle
    cy = np.sqrt(cy_sq)
    sx = (rv * rv - ru * ru + length * length) / (2.0 * length)
    sy_sq = rv * rv - sx * sx
    if sy_sq < -_SLACK * length * length:
        return np.inf  # the two distances are inconsistent: no such point
    sy = -np.sqrt(max(sy_sq, 0.0))
    # where the segment from the source to c crosses the line of the edge (y = 0)
    x = sx + (cx - sx) * (-sy) / (cy - sy)
    if x < -_SLACK * length or x > length * (1.0 + _SLACK):
        return np.inf
    return np.sqrt((cx - sx) * (cx - sx) + (cy - sy) * (cy - sy))


@kernel(inline="always")
def _relax(heap, dist, sigma, pseudo, root, c, cand, via, via_sigma, via_root):
    """Take ``cand`` for vertex ``c`` if it is shorter, or ties and bends less; push ``c``."""
    current = dist[c]
    better = cand < current * (1.0 - _SLACK)
    tie = (not better) and cand <= current * (1.0 + _SLACK) and via_sigma < sigma[c] * (1.0 - _SLACK)
    if better or tie:
        # a tie takes the candidate's own value too (at most the slack longer), so a vertex's
        # distance stays consistent with its pseudo-source for the unfolding that uses it
        dist[c] = cand
        sigma[c] = via_sigma
        pseudo[c] = via
        root[c] = via_root
        heapq.heappush(heap, (dist[c], np.int64(c)))


def geodesic_distances(
    pos: np.ndarray, triangles: np.ndarray, sources: np.ndarray, max_updates: int | None = None
) -> tuple[np.ndarray, np.ndarray, bool]:
    """Geodesic distance of every vertex from the nearest of ``sources`` (module docstring).

    Args:
        pos: (n,3) vertex positions.
        triangles: (t,3) vertex indices.
        sources: (s,) source vertex indices.
        max_updates: the work budget in vertex updates; default 50 per vertex (a regular sheet
            takes about 1.2).

    Returns (dist f64 (n,), inf where no path; root i64 (n,), the source each path starts at,
    -1 where none; done: False if the budget ran out, and the result must not be used).
    """
    pos = np.ascontiguousarray(pos, np.float64)
    triangles = np.ascontiguousarray(triangles, np.int64).reshape(-1, 3)
    n = pos.shape[0]
    order = np.argsort(triangles.reshape(-1), kind="stable")
    vertex_triangles = (order // 3).astype(np.int64)
    offsets = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(triangles.reshape(-1), minlength=n), out=offsets[1:])
    budget = 50 * n + 1 if max_updates is None else int(max_updates)
    return _geodesic_from_sources(
        pos, triangles, offsets, vertex_triangles, np.ascontiguousarray(sources, np.int64), budget
    )
