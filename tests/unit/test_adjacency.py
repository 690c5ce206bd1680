"""AdjacencyQuerier against brute-force references on random meshes."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.cook.adjacency import AdjacencyQuerier, csr_from_pairs


def random_polygon_mesh(rng: np.random.Generator, n: int, f: int):
    counts = rng.integers(3, 6, size=f).astype(np.int32)
    faces = [rng.choice(n, size=c, replace=False) for c in counts]
    return counts, np.concatenate(faces).astype(np.int64), faces


def brute_force(n, faces):
    neighbors = [set() for _ in range(n)]
    vertex_faces = [[] for _ in range(n)]
    edge_faces: dict[tuple[int, int], list[int]] = {}
    for fi, face in enumerate(faces):
        for k, v in enumerate(face):
            w = face[(k + 1) % len(face)]
            neighbors[v].add(int(w))
            neighbors[w].add(int(v))
            edge_faces.setdefault((min(v, w), max(v, w)), []).append(fi)
            vertex_faces[v].append(fi)
    return neighbors, vertex_faces, edge_faces


@pytest.mark.parametrize("seed", range(8))
def test_adjacency_matches_brute_force(seed):
    rng = np.random.default_rng(seed)
    n, f = 30, 25
    counts, indices, faces = random_polygon_mesh(rng, n, f)
    adj = AdjacencyQuerier(counts, indices, n)
    neighbors, vertex_faces, edge_faces = brute_force(n, faces)

    assert adj.edge_count == len(edge_faces)
    assert [tuple(e) for e in adj.edges.tolist()] == sorted(edge_faces)
    for v in range(n):
        assert adj.neighbors(v).tolist() == sorted(neighbors[v])
        assert adj.faces_of_particle(v).tolist() == vertex_faces[v]
        assert adj.degree()[v] == len(neighbors[v])
    for (a, b), expected in edge_faces.items():
        e = adj.edge_index(a, b)
        assert e >= 0 and adj.edge_index(b, a) == e
        assert sorted(adj.faces_of_edge(e).tolist()) == sorted(expected)
    # a pair that is not an edge
    missing = [(a, b) for a in range(n) for b in range(a + 1, n) if (a, b) not in edge_faces][0]
    assert adj.edge_index(*missing) == -1
    pairs = np.array([[a, b] for (a, b) in edge_faces] + [list(missing)])
    found = adj.edge_indices(pairs)
    assert (found[:-1] >= 0).all() and found[-1] == -1


def test_boundary_particles_of_a_quad_strip():
    # two quads side by side: every vertex is on the boundary; the shared edge is interior
    counts = np.array([4, 4])
    indices = np.array([0, 1, 4, 3, 1, 2, 5, 4])
    adj = AdjacencyQuerier(counts, indices, 6)
    assert adj.boundary_particles().all()
    shared = adj.edge_index(1, 4)
    assert adj.edge_face_count()[shared] == 2
    assert sorted(adj.faces_of_edge(shared).tolist()) == [0, 1]


def test_csr_from_pairs_is_stable_count_prefix_scatter():
    rows = np.array([2, 0, 2, 1, 0])
    cols = np.array([10, 11, 12, 13, 14])
    offsets, values = csr_from_pairs(rows, cols, 4)
    assert offsets.tolist() == [0, 2, 3, 5, 5]
    assert values.tolist() == [11, 14, 13, 10, 12]
