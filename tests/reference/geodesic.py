"""Reference for clothtool.cook.geodesic (geodesic distances by unfolding), in plain Python.

The same propagation as the kernel, written for reading: each candidate unfolds the
pseudo-source into the triangle's plane with numpy vectors instead of the kernel's scalar
2D frame.
"""

from __future__ import annotations

import heapq

import numpy as np

SLACK = 1e-6


def _corner_of(triangles, t, v):
    return int(list(triangles[t]).index(v))


def _distance_sq(pos, a, b):
    return float(np.sum((pos[b] - pos[a]) ** 2))


def _unfolded(pos, v, u, c, rv, ru):
    """Distance to ``c`` from the point at ``rv`` from ``v`` and ``ru`` from ``u`` on the far
    side of edge ``vu`` (in triangle (v,u,c)'s plane); inf if that segment misses the edge."""
    edge = pos[u] - pos[v]
    length = float(np.linalg.norm(edge))
    if length == 0.0:
        return np.inf
    x_axis = edge / length
    to_c = pos[c] - pos[v]
    height = to_c - np.dot(to_c, x_axis) * x_axis
    if float(np.dot(height, height)) <= 0.0:
        return np.inf
    c2 = np.array([np.dot(to_c, x_axis), np.linalg.norm(height)])
    sx = (rv**2 - ru**2 + length**2) / (2 * length)
    sy_sq = rv**2 - sx**2
    if sy_sq < -SLACK * length**2:
        return np.inf
    source = np.array([sx, -np.sqrt(max(sy_sq, 0.0))])
    crossing = source[0] + (c2[0] - source[0]) * (-source[1]) / (c2[1] - source[1])
    if not (-SLACK * length <= crossing <= length * (1 + SLACK)):
        return np.inf
    return float(np.linalg.norm(c2 - source))


def _relax(heap, dist, sigma, pseudo, root, c, cand, via, via_sigma, via_root):
    better = cand < dist[c] * (1 - SLACK)
    tie = not better and cand <= dist[c] * (1 + SLACK) and via_sigma < sigma[c] * (1 - SLACK)
    if better or tie:
        dist[c], sigma[c], pseudo[c], root[c] = cand, via_sigma, via, via_root
        heapq.heappush(heap, (float(dist[c]), int(c)))


def _geodesic_from_sources(pos, triangles, vertex_triangle_offsets, vertex_triangles, sources, max_updates):
    n = pos.shape[0]
    dist = np.full(n, np.inf)
    sigma = np.zeros(n)
    pseudo = np.full(n, -1, np.int64)
    root = np.full(n, -1, np.int64)
    heap = []
    for s in sources:
        dist[s], pseudo[s], root[s] = 0.0, s, s
        heapq.heappush(heap, (0.0, int(s)))
    updates = 0
    while heap:
        d, v = heapq.heappop(heap)
        if d != dist[v]:
            continue
        updates += 1
        if updates > max_updates:
            return dist, root, False
        for t in vertex_triangles[vertex_triangle_offsets[v] : vertex_triangle_offsets[v + 1]]:
            for corner in range(3):
                u = int(triangles[t, corner])
                if u == v:
                    continue
                c = int(triangles[t, 3 - corner - _corner_of(triangles, t, v)])
                _relax(heap, dist, sigma, pseudo, root, u, d + np.sqrt(_distance_sq(pos, v, u)), v, d, root[v])
                if pseudo[u] == pseudo[v] and sigma[u] == sigma[v] and np.isfinite(dist[u]) and c != u:
                    cand = _unfolded(pos, v, u, c, d - sigma[v], dist[u] - sigma[v])
                    if np.isfinite(cand):
                        _relax(heap, dist, sigma, pseudo, root, c, sigma[v] + cand, pseudo[v], sigma[v], root[v])
    return dist, root, True
