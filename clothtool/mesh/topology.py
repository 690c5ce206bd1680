"""Topology as free functions over flat arrays: faces, edges, triangulation, welding.

Faces are given in USD form: ``counts`` (f,) and ``indices`` (sum(counts),). All functions
are vectorised (no Python loop over elements) so that a million-particle garment cooks in
seconds.
"""

from __future__ import annotations

import numpy as np


def face_offsets(counts: np.ndarray) -> np.ndarray:
    """i64 (f+1,) CSR offsets of each face into the flat index array."""
    offsets = np.zeros(counts.shape[0] + 1, np.int64)
    np.cumsum(counts, out=offsets[1:])
    return offsets


def corner_face(counts: np.ndarray) -> np.ndarray:
    """i64 (fv,) the face each face corner belongs to."""
    return np.repeat(np.arange(counts.shape[0], dtype=np.int64), counts)


def next_corner(counts: np.ndarray) -> np.ndarray:
    """i64 (fv,) for every face corner, the index of the next corner of the same face."""
    offsets = face_offsets(counts)
    corners = np.arange(offsets[-1], dtype=np.int64)
    following = corners + 1
    last = offsets[1:] - 1
    following[last] = offsets[:-1]
    return following


def half_edges(counts: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """i64 (fv,2) directed edge (v, next v) of every face corner, in face winding order."""
    return np.stack([indices, indices[next_corner(counts)]], axis=1).astype(np.int64)


def triangulate(counts: np.ndarray, indices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fan-triangulate polygons (as USD and most DCCs do).

    Returns (triangles i64 (t,3), triangle_face i64 (t,)).
    """
    offsets = face_offsets(counts)
    tri_per_face = np.maximum(counts.astype(np.int64) - 2, 0)
    tri_face = np.repeat(np.arange(counts.shape[0], dtype=np.int64), tri_per_face)
    first_tri = np.zeros(counts.shape[0] + 1, np.int64)
    np.cumsum(tri_per_face, out=first_tri[1:])
    local = np.arange(tri_face.shape[0], dtype=np.int64) - first_tri[tri_face]
    base = offsets[tri_face]
    triangles = np.stack(
        [indices[base], indices[base + local + 1], indices[base + local + 2]], axis=1
    ).astype(np.int64)
    return triangles, tri_face


def edge_keys(edges: np.ndarray, vertex_count: int) -> np.ndarray:
    """Unique int64 key of each undirected edge (order of the two vertices ignored)."""
    lo = np.minimum(edges[:, 0], edges[:, 1]).astype(np.int64)
    hi = np.maximum(edges[:, 0], edges[:, 1]).astype(np.int64)
    return lo * np.int64(vertex_count) + hi


def unique_edges(
    directed: np.ndarray, vertex_count: int
) -> tuple[np.ndarray, np.ndarray]:
    """Undirected unique edges of a set of directed edges.

    Returns (edges i64 (e,2) with edges[:,0] < edges[:,1], sorted by key;
    inverse i64 (len(directed),) mapping each directed edge to its unique edge).
    """
    keys = edge_keys(directed, vertex_count)
    unique, inverse = np.unique(keys, return_inverse=True)
    edges = np.stack([unique // vertex_count, unique % vertex_count], axis=1)
    return edges, inverse.reshape(-1)


def triangle_areas(pos: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """f64 (t,) area of each triangle."""
    p = pos.astype(np.float64)
    cross = np.cross(p[triangles[:, 1]] - p[triangles[:, 0]], p[triangles[:, 2]] - p[triangles[:, 0]])
    return 0.5 * np.linalg.norm(cross, axis=1)


def triangle_min_angles(pos: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """f64 (t,) smallest interior angle of each triangle, in degrees."""
    p = pos.astype(np.float64)
    a, b, c = p[triangles[:, 0]], p[triangles[:, 1]], p[triangles[:, 2]]
    angles = []
    for u, v, w in ((a, b, c), (b, c, a), (c, a, b)):
        e1, e2 = v - u, w - u
        cos = np.einsum("ij,ij->i", e1, e2) / np.maximum(
            np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1), 1e-300
        )
        angles.append(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
    return np.min(angles, axis=0)


def vertex_areas(pos: np.ndarray, counts: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """f64 (n,) lumped area per vertex: each polygon's area split evenly among its corners.

    (Splitting the fan triangles instead would give a quad's first corner twice the share
    of the others, and a uniform quad grid uneven masses.)
    """
    triangles, tri_face = triangulate(counts, indices)
    face_area = np.bincount(tri_face, weights=triangle_areas(pos, triangles), minlength=counts.shape[0])
    share = np.repeat(face_area / counts, counts)
    return np.bincount(indices, weights=share, minlength=pos.shape[0])


def weld_map(pos: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """Merge vertices closer than ``tolerance`` (absolute, in mesh units).

    Clusters are the connected components of the "closer than tolerance" graph. The kept
    vertex of a cluster is its lowest index, and kept vertices stay in their original order,
    so the result is deterministic.

    Returns (remap i64 (n,) old -> new index, kept i64 (m,) old index of each new vertex).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    n = pos.shape[0]
    if tolerance <= 0 or n < 2:
        return np.arange(n, dtype=np.int64), np.arange(n, dtype=np.int64)
    pairs = cKDTree(pos.astype(np.float64)).query_pairs(tolerance, output_type="ndarray")
    if pairs.shape[0] == 0:
        return np.arange(n, dtype=np.int64), np.arange(n, dtype=np.int64)
    graph = coo_matrix((np.ones(pairs.shape[0], np.int8), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    # representative of each cluster = its smallest vertex index
    representative = np.full(labels.max() + 1, n, np.int64)
    np.minimum.at(representative, labels, np.arange(n, dtype=np.int64))
    rep_of_vertex = representative[labels]
    kept = np.flatnonzero(rep_of_vertex == np.arange(n))
    new_index = np.full(n, -1, np.int64)
    new_index[kept] = np.arange(kept.shape[0])
    return new_index[rep_of_vertex], kept
