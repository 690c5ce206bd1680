"""Tethers: long-range max-distance constraints from free particles to pinned ones.

Pinned particles form *islands* (pinned particles connected by mesh edges: a waistband, a
shoulder seam, a corner). Each free particle is tethered to its nearest pinned particle in
each of its ``k`` nearest islands. The rest length is the geodesic distance over the mesh's
triangles (clothtool.cook.geodesic: exact on developable sheets, where the edge graph's
shortest path was up to 8% long from a pinned corner of a grid and 41% from a pin in its
middle, and let cloth sag below its tethers' intent), or the
straight-line distance. The anchor is the pinned particle the geodesic starts from, reported
by the same propagation, so the length is the distance to that very particle.

Fallbacks, each reported in ``TetherBuild.notes`` for the cook's warnings: an island whose
propagation runs out of its work budget (a mesh it cannot unfold cleanly) gets edge-graph
distances (scipy's dijkstra, never shorter than the geodesic); particles with no path over the
mesh to any pinned particle get straight-line tethers.

Layout (NvCloth's): ``anchor[s * n + i]`` and ``length[s * n + i]`` are tether slot ``s`` of
particle ``i``. Pinned particles, and slots a particle has no island for, hold the particle
itself with length 0, which the solver's tether stage leaves unmoved.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from clothtool.cook.geodesic import GeodesicSolver


@dataclasses.dataclass(frozen=True)
class TetherBuild:
    """Tethers in NvCloth's layout (module docstring) and what the build had to fall back on."""

    anchor: np.ndarray  # i32 (k*n,)
    length: np.ndarray  # f32 (k*n,)
    unreachable: int  # free particles with no path over the mesh: straight-line tethers
    graph_islands: int  # islands whose geodesics fell back to edge-graph distances
    notes: tuple[str, ...]  # one line per fallback, for the cook's warnings


def pinned_islands(pinned: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, int]:
    """Island id (0..I-1, numbered by lowest particle index) of each pinned particle, -1 elsewhere."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = pinned.shape[0]
    both = pinned[edges[:, 0]] & pinned[edges[:, 1]]
    e = edges[both]
    graph = coo_matrix((np.ones(e.shape[0], np.int8), (e[:, 0], e[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    labels = np.where(pinned, labels, -1)
    # renumber islands 0..I-1 in order of their lowest particle
    pinned_labels = labels[pinned]
    _, first = np.unique(pinned_labels, return_index=True)
    ordered = pinned_labels[np.sort(first)]
    renumber = np.full(labels.max() + 2 if labels.size else 1, -1, np.int64)
    renumber[ordered] = np.arange(ordered.shape[0])
    return np.where(pinned, renumber[labels], -1), int(ordered.shape[0])


def _graph(pos: np.ndarray, edges: np.ndarray):
    from scipy.sparse import csr_matrix

    n = pos.shape[0]
    p = pos.astype(np.float64)
    lengths = np.linalg.norm(p[edges[:, 1]] - p[edges[:, 0]], axis=1)
    # csgraph treats explicit zeros as missing edges; a zero-length edge still connects.
    lengths = np.maximum(lengths, 1e-30)
    return csr_matrix((lengths, (edges[:, 0], edges[:, 1])), shape=(n, n))


def _nearest_in_island_graph(graph, members: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    from scipy.sparse.csgraph import dijkstra

    dist, _, sources = dijkstra(graph, directed=False, indices=members, return_predecessors=True, min_only=True)
    return dist, sources


def _nearest_in_island_geodesic(
    solver: GeodesicSolver, members: np.ndarray, max_updates: int | None
) -> tuple[np.ndarray, np.ndarray] | None:
    """(distance, anchor) from the island over the triangles, or None if the budget ran out."""
    pos = solver.pos
    dist, root, done = solver.distances(members, max_updates)
    if not done:
        return None
    # a geodesic is never shorter than the straight line; on curved patches the unfolding
    # is approximate and this keeps it honest
    reached = root >= 0
    straight = np.linalg.norm(pos[np.where(reached, root, 0)] - pos, axis=1)
    return np.where(reached, np.maximum(dist, straight), np.inf), np.where(reached, root, -1)


def _nearest_in_island_euclidean(pos: np.ndarray, members: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    from scipy.spatial import cKDTree

    dist, which = cKDTree(pos[members].astype(np.float64)).query(pos.astype(np.float64))
    return dist, members[which]


def build_tethers(
    pos: np.ndarray,
    edges: np.ndarray,
    triangles: np.ndarray,
    pinned: np.ndarray,
    mode: str,
    anchors_per_particle: int = 1,
    max_updates: int | None = None,
) -> TetherBuild:
    """Tether anchors and rest lengths (see the module docstring for the layout).

    Args:
        pos: (n,3) rest positions.
        edges: (e,2) constraint graph: islands, and the fallback's graph distances.
        triangles: (t,3) the surface geodesics run over.
        pinned: bool (n,) pinned particles (at least one).
        mode: "geodesic" or "euclidean".
        anchors_per_particle: the number of tether slots per particle wanted; the result has
            k = min(that, number of pinned islands) slots.
        max_updates: work budget of one island's geodesic propagation (default: the
            propagation's own, 50 updates per particle); past it the island falls back.
    """
    pos = np.asarray(pos, np.float64)
    n = pos.shape[0]
    islands, island_count = pinned_islands(pinned, edges)
    # more slots than islands would only add inactive slots, which still dilute the tether
    # stiffness (NvCloth divides it by the slot count); so, as NvCloth, cap k at the islands
    k = max(1, min(int(anchors_per_particle), island_count))
    best_dist = np.full((k, n), np.inf)
    best_anchor = np.tile(np.arange(n, dtype=np.int64), (k, 1))
    graph = None
    solver = GeodesicSolver(pos, triangles) if mode == "geodesic" else None
    graph_islands = []
    for island in range(island_count):
        members = np.flatnonzero(islands == island)
        if mode == "geodesic":
            found = _nearest_in_island_geodesic(solver, members, max_updates)
            if found is None:
                graph_islands.append(island)
                graph = _graph(pos, edges) if graph is None else graph
                found = _nearest_in_island_graph(graph, members)
            dist, anchor = found
        else:
            dist, anchor = _nearest_in_island_euclidean(pos, members)
        # merge into the running k nearest islands (stable: earlier islands win ties)
        all_dist = np.vstack([best_dist, dist[None, :]])
        all_anchor = np.vstack([best_anchor, np.where(np.isfinite(dist), anchor, np.arange(n))[None, :]])
        order = np.argsort(all_dist, axis=0, kind="stable")[:k]
        best_dist = np.take_along_axis(all_dist, order, axis=0)
        best_anchor = np.take_along_axis(all_anchor, order, axis=0)

    fallback = np.zeros(n, bool)
    if mode == "geodesic":
        # particles on a piece of mesh with no pinned particle: geodesics are undefined there
        fallback = ~np.isfinite(best_dist[0]) & ~pinned
        if fallback.any():
            straight = build_tethers(pos, edges, triangles, pinned, "euclidean", k)
            best_anchor[:, fallback] = straight.anchor.reshape(k, n)[:, fallback]
            best_dist[:, fallback] = straight.length.reshape(k, n)[:, fallback]

    unused = ~np.isfinite(best_dist)
    best_anchor[unused] = np.broadcast_to(np.arange(n), best_anchor.shape)[unused]
    best_dist[unused] = 0.0
    best_anchor[:, pinned] = np.flatnonzero(pinned)
    best_dist[:, pinned] = 0.0
    notes = []
    if graph_islands:
        notes.append(
            f"{len(graph_islands)} of {island_count} pinned islands (first: the one holding particle "
            f"{int(np.flatnonzero(islands == graph_islands[0])[0])}) ran out of the geodesic propagation's "
            "work budget; their tethers use edge-graph distances, up to 8% longer than geodesic "
            "(check the mesh for folded or overlapping triangles there)"
        )
    if fallback.any():
        notes.append(
            f"{int(fallback.sum())} particles have no path over the mesh to a pinned particle; "
            "their tethers are straight lines (pin each separate piece to get geodesic tethers)"
        )
    return TetherBuild(
        anchor=best_anchor.reshape(-1).astype(np.int32),
        length=best_dist.reshape(-1).astype(np.float32),
        unreachable=int(fallback.sum()),
        graph_islands=len(graph_islands),
        notes=tuple(notes),
    )
