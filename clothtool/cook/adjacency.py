"""AdjacencyQuerier: compact CSR adjacency of a polygon mesh.

Three relations, each a CSR pair (offsets, values) built by count, prefix sum and scatter:
particle -> neighbouring particles (through face edges), particle -> faces, and
edge -> faces. Edges are the mesh's unique undirected face edges, sorted by (lo, hi).
"""

from __future__ import annotations

import numpy as np

from clothtool.mesh import topology


def csr_from_pairs(rows: np.ndarray, cols: np.ndarray, row_count: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR (offsets i64 (row_count+1,), values i64) of the pairs (rows[i], cols[i]).

    Count per row, prefix-sum into offsets, then scatter each value to its slot; values
    inside a row keep their input order (stable).
    """
    counts = np.bincount(rows, minlength=row_count)
    offsets = np.zeros(row_count + 1, np.int64)
    np.cumsum(counts, out=offsets[1:])
    order = np.argsort(rows, kind="stable")
    return offsets, cols[order].astype(np.int64)


class AdjacencyQuerier:
    """Adjacency queries over a polygon mesh (counts/indices in USD form)."""

    def __init__(self, face_vertex_counts: np.ndarray, face_vertex_indices: np.ndarray, particle_count: int):
        self.particle_count = int(particle_count)
        self.face_vertex_counts = np.asarray(face_vertex_counts)
        self.face_vertex_indices = np.asarray(face_vertex_indices, np.int64)
        counts = self.face_vertex_counts
        half = topology.half_edges(counts, self.face_vertex_indices)
        corner_face = topology.corner_face(counts)

        # edges and edge -> faces
        self.edges, half_to_edge = topology.unique_edges(half, self.particle_count)
        self.edge_face_offsets, self.edge_faces = csr_from_pairs(half_to_edge, corner_face, self.edges.shape[0])

        # particle -> particles: both directions of every unique edge, sorted by neighbour
        rows = np.concatenate([self.edges[:, 0], self.edges[:, 1]])
        cols = np.concatenate([self.edges[:, 1], self.edges[:, 0]])
        order = np.lexsort((cols, rows))
        self.neighbor_offsets, self.neighbors_flat = csr_from_pairs(rows[order], cols[order], self.particle_count)

        # particle -> faces (a face listed once per particle even if a vertex repeats)
        self.face_offsets_of_particle, self.particle_faces = csr_from_pairs(
            self.face_vertex_indices, corner_face, self.particle_count
        )
        self._edge_keys = topology.edge_keys(self.edges, self.particle_count)

    # ------------------------------------------------------------------ queries
    @property
    def edge_count(self) -> int:
        return int(self.edges.shape[0])

    def degree(self) -> np.ndarray:
        """i64 (n,) number of neighbouring particles of each particle."""
        return np.diff(self.neighbor_offsets)

    def neighbors(self, particle: int) -> np.ndarray:
        return self.neighbors_flat[self.neighbor_offsets[particle] : self.neighbor_offsets[particle + 1]]

    def faces_of_particle(self, particle: int) -> np.ndarray:
        lo, hi = self.face_offsets_of_particle[particle], self.face_offsets_of_particle[particle + 1]
        return self.particle_faces[lo:hi]

    def edge_index(self, a: int, b: int) -> int:
        """Index of the edge (a, b) in ``edges``, or -1 if there is no such edge."""
        key = topology.edge_keys(np.array([[a, b]], np.int64), self.particle_count)[0]
        i = int(np.searchsorted(self._edge_keys, key))
        return i if i < self._edge_keys.shape[0] and self._edge_keys[i] == key else -1

    def edge_indices(self, pairs: np.ndarray) -> np.ndarray:
        """Vectorised ``edge_index`` for (m,2) pairs; -1 where there is no edge."""
        keys = topology.edge_keys(np.asarray(pairs, np.int64), self.particle_count)
        i = np.searchsorted(self._edge_keys, keys)
        i = np.minimum(i, max(self.edge_count - 1, 0))
        found = self._edge_keys[i] == keys if self.edge_count else np.zeros(keys.shape, bool)
        return np.where(found, i, -1)

    def faces_of_edge(self, edge: int) -> np.ndarray:
        return self.edge_faces[self.edge_face_offsets[edge] : self.edge_face_offsets[edge + 1]]

    def edge_face_count(self) -> np.ndarray:
        """i64 (e,) number of faces around each edge (1 = boundary, 2 = interior)."""
        return np.diff(self.edge_face_offsets)

    def boundary_particles(self) -> np.ndarray:
        """Boolean (n,) mask of particles on a boundary edge."""
        mask = np.zeros(self.particle_count, bool)
        mask[self.edges[self.edge_face_count() == 1].reshape(-1)] = True
        return mask
