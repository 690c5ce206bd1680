"""Particle order for memory locality: neighbours on the mesh become neighbours in memory.

A garment from a DCC arrives with its vertices in whatever order the modelling history left
them. The solver sweeps every conflict-free set over the particle arrays many times per
frame; when a constraint's two particles lie far apart in memory, each touch of a big cloth
is a cache miss. The cook therefore renumbers the particles by the reverse Cuthill-McKee
order of the mesh's edge graph (scipy), which keeps every edge's two particles within a
narrow band of indices; the scheduler then sorts each set's constraints by particle index
(clothtool.mesh.coloring), so a sweep walks memory almost sequentially.

Reverse Cuthill-McKee was measured against a 3-D Morton (Z-order) curve over the rest
positions (``python benchmarks/locality.py``, one thread, CPU ns per particle-iteration): on a
1000^2 grid whose vertices arrive shuffled, vertex order costs 93 ns, RCM 55 and Morton 63,
against 50-52 for the scanline grid (10k particles: 28-30 in every order). RCM also needs no
grid resolution, follows the surface rather than the embedding (two layers of a folded
garment that touch in space stay apart) and gives the greedy scheduler as few sets as the
scanline order (12 on a grid; Morton 14), so it is the cook's order.

The order alone leaves the big cloth 1.6-1.9x dearer per particle than 10k: every
conflict-free set still spans the whole cloth, so each of a grid's twelve sets reads the
whole state from memory. Cloths over 16384 particles are therefore also cooked in cache
tiles (clothtool.cook.tiles), which brings 1M particles to within 1.1x of 10k (scanline
grid, RCM: 33.4 against 31.9 ns per particle-iteration, from 53.0 against 32.3 untiled).

The renumbering is a permutation recorded in the fabric (``Fabric.particle_vertex``), so
caches still present points in the input mesh's vertex order.
"""

from __future__ import annotations

import numpy as np

from clothtool.mesh import topology
from clothtool.mesh.clothmesh import ClothMesh


def edge_graph(vertex_count: int, counts: np.ndarray, indices: np.ndarray):
    """The mesh's undirected edge graph as a symmetric scipy CSR matrix (n x n)."""
    from scipy.sparse import coo_matrix

    edges, _ = topology.unique_edges(topology.half_edges(counts, indices), vertex_count)
    rows = np.concatenate([edges[:, 0], edges[:, 1]])
    cols = np.concatenate([edges[:, 1], edges[:, 0]])
    ones = np.ones(rows.shape[0], np.int8)
    return coo_matrix((ones, (rows, cols)), shape=(vertex_count, vertex_count)).tocsr()


def rcm_order(mesh: ClothMesh) -> np.ndarray:
    """i64 (n,): the vertex of ``mesh`` that becomes particle i, by reverse Cuthill-McKee.

    Deterministic: scipy starts each connected piece from a vertex of lowest degree and
    breaks ties by vertex index.
    """
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    graph = edge_graph(mesh.vertex_count, mesh.face_vertex_counts, mesh.face_vertex_indices)
    return reverse_cuthill_mckee(graph, symmetric_mode=True).astype(np.int64)


def _spread_bits(values: np.ndarray) -> np.ndarray:
    """Put bit k of each (up to 21-bit) value at bit 3k, for interleaving three coordinates."""
    x = values.astype(np.uint64) & np.uint64(0x1FFFFF)
    for shift, mask in ((32, 0x1F00000000FFFF), (16, 0x1F0000FF0000FF), (8, 0x100F00F00F00F00F),
                        (4, 0x10C30C30C30C30C3), (2, 0x1249249249249249)):
        x = (x | (x << np.uint64(shift))) & np.uint64(mask)
    return x


def morton_order(mesh: ClothMesh, bits: int = 21) -> np.ndarray:
    """i64 (n,): the vertex that becomes particle i, by a 3-D Morton (Z-order) curve over the
    rest positions quantised to ``bits`` bits per axis (ties by vertex index)."""
    pos = mesh.vertex_pos.astype(np.float64)
    lo, hi = pos.min(axis=0), pos.max(axis=0)
    scale = (2**bits - 1) / max(float((hi - lo).max()), np.finfo(np.float64).tiny)
    cells = np.floor((pos - lo) * scale).astype(np.int64)
    code = _spread_bits(cells[:, 0]) | (_spread_bits(cells[:, 1]) << np.uint64(1)) | (_spread_bits(cells[:, 2]) << np.uint64(2))
    return np.argsort(code, kind="stable").astype(np.int64)


def inverse_permutation(order: np.ndarray) -> np.ndarray:
    """i64 (n,): the position of each value in the permutation ``order``."""
    inverse = np.empty(order.shape[0], np.int64)
    inverse[order] = np.arange(order.shape[0], dtype=np.int64)
    return inverse


def reorder_mesh(mesh: ClothMesh, order: np.ndarray) -> ClothMesh:
    """``mesh`` with its vertices renumbered: new vertex i is old vertex ``order[i]``.

    Faces keep their order and winding (UVs live on face corners and so are unchanged);
    positions and painted attributes move with their vertices.
    """
    new_index = inverse_permutation(order)
    return mesh.replace(
        vertex_pos=mesh.vertex_pos[order],
        face_vertex_indices=new_index[mesh.face_vertex_indices],
        vertex_attrs={name: values[order] for name, values in mesh.vertex_attrs.items()},
    )


def renumber_vertex_map(vertex_map: np.ndarray, order: np.ndarray) -> np.ndarray:
    """A file-vertex -> vertex map after ``reorder_mesh(.., order)``; -1 (removed) stays -1."""
    new_index = inverse_permutation(order)
    return np.where(vertex_map >= 0, new_index[np.maximum(vertex_map, 0)], -1)
