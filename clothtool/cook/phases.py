"""Classify a mesh's constraints into phases, as NvCloth's cooker does.

* stretch: every face edge that is not a quad diagonal, split into *vertical* (closer to the
  hang direction than 45 degrees) and *horizontal*;
* shearing: both diagonals of every quad (quads from the file, or recovered from pairs of
  triangles whose shared edge is the longest edge of both);
* bending: pairs of particles two stretch edges apart across a middle particle, where the two
  edges are each other's most collinear continuation (the 2-ring "straight line" pairs).

Rest lengths come from the cooking pose.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from clothtool._jit import kernel
from clothtool.cook.adjacency import AdjacencyQuerier, csr_from_pairs
from clothtool.fabric import PhaseType
from clothtool.mesh import topology

# Recovered quads must be nearly planar: the two triangles' normals within this angle.
QUAD_RECOVERY_MAX_FOLD_DEG = 30.0
# A bending pair needs the angle at the middle particle to exceed this (180 = straight).
BENDING_MIN_ANGLE_DEG = 135.0
# A stretch edge closer than this angle to the hang direction is vertical.
VERTICAL_MAX_ANGLE_DEG = 45.0


@dataclasses.dataclass(frozen=True)
class PhaseConstraints:
    """Constraints of one phase, before scheduling: (c,2) particle pairs, lo < hi."""

    phase_type: PhaseType
    pairs: np.ndarray


def _quads_from_file(counts: np.ndarray, indices: np.ndarray) -> np.ndarray:
    offsets = topology.face_offsets(counts)
    starts = offsets[:-1][counts == 4]
    return np.stack([indices[starts + i] for i in range(4)], axis=1).astype(np.int64)


def _recover_quads(pos: np.ndarray, counts: np.ndarray, indices: np.ndarray, adjacency: AdjacencyQuerier):
    """Pair triangles into quads across their shared longest edge.

    Returns (quads i64 (q,4) in winding order, diagonal_edges i64 (q,) the shared edges).
    """
    offsets = topology.face_offsets(counts)
    tri_faces = np.flatnonzero(counts == 3)
    empty = (np.zeros((0, 4), np.int64), np.zeros(0, np.int64))
    if tri_faces.size < 2:
        return empty
    tri = np.stack([indices[offsets[tri_faces] + i] for i in range(3)], axis=1).astype(np.int64)
    p = pos.astype(np.float64)
    # edge j of a triangle is (tri[j], tri[j+1]); find each triangle's strictly longest edge
    ends = np.roll(tri, -1, axis=1)
    lengths = np.linalg.norm(p[ends] - p[tri], axis=2)
    longest = np.argmax(lengths, axis=1)
    sorted_len = np.sort(lengths, axis=1)
    strict = sorted_len[:, 2] > sorted_len[:, 1] * (1 + 1e-4)
    rows = np.arange(tri.shape[0])
    long_a, long_b = tri[rows, longest], ends[rows, longest]
    edge = adjacency.edge_indices(np.stack([long_a, long_b], axis=1))
    # an edge is a recovered diagonal when exactly two triangles call it their longest
    candidate = strict & (edge >= 0)
    cand_edges = edge[candidate]
    cand_tris = rows[candidate]
    order = np.argsort(cand_edges, kind="stable")
    cand_edges, cand_tris = cand_edges[order], cand_tris[order]
    paired = np.flatnonzero(cand_edges[1:] == cand_edges[:-1])
    # an edge with three claimants cannot occur on a manifold mesh (prepare_mesh checks that)
    t1, t2 = cand_tris[paired], cand_tris[paired + 1]
    diag = cand_edges[paired]
    if t1.size == 0:
        return empty
    # planarity: the normals of both triangles within QUAD_RECOVERY_MAX_FOLD_DEG
    def normal(t):
        n = np.cross(p[tri[t, 1]] - p[tri[t, 0]], p[tri[t, 2]] - p[tri[t, 0]])
        return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)

    flat = np.einsum("ij,ij->i", normal(t1), normal(t2)) > np.cos(np.radians(QUAD_RECOVERY_MAX_FOLD_DEG))
    t1, t2, diag = t1[flat], t2[flat], diag[flat]
    # quad in winding order: start after the diagonal in t1 -> (a, opposite1, b, opposite2)
    i1 = longest[t1]
    a = tri[t1, i1]
    b = ends[t1, i1]
    opposite1 = tri[t1, (i1 + 2) % 3]
    opposite2 = (tri[t2].sum(axis=1) - long_a[t2] - long_b[t2])
    quads = np.stack([b, opposite1, a, opposite2], axis=1)
    return quads, diag


@kernel
def _bending_pairs(neighbor_offsets, neighbors, pos, cos_limit):
    """Pairs (i, k) with a middle particle j where j->i and j->k are each other's most
    opposite neighbour directions and the angle i-j-k exceeds the limit."""
    n = neighbor_offsets.shape[0] - 1
    max_deg = 0
    for j in range(n):
        max_deg = max(max_deg, neighbor_offsets[j + 1] - neighbor_offsets[j])
    out = np.empty((n * max_deg // 2 + 1, 2), np.int64)
    count = 0
    dirs = np.empty((max_deg, 3))
    best = np.empty(max_deg, np.int64)
    best_cos = np.empty(max_deg)
    for j in range(n):
        lo = neighbor_offsets[j]
        deg = neighbor_offsets[j + 1] - lo
        for a in range(deg):
            i = neighbors[lo + a]
            length = 0.0
            for d in range(3):
                dirs[a, d] = pos[i, d] - pos[j, d]
                length += dirs[a, d] * dirs[a, d]
            length = np.sqrt(length)
            for d in range(3):
                dirs[a, d] /= max(length, 1e-300)
            best[a] = -1
            best_cos[a] = 2.0
        for a in range(deg):
            for b in range(deg):
                if a != b:
                    c = dirs[a, 0] * dirs[b, 0] + dirs[a, 1] * dirs[b, 1] + dirs[a, 2] * dirs[b, 2]
                    if c < best_cos[a]:
                        best_cos[a] = c
                        best[a] = b
        for a in range(deg):
            b = best[a]
            if b > a and best[b] == a and best_cos[a] < cos_limit:
                i = neighbors[lo + a]
                k = neighbors[lo + b]
                out[count, 0] = min(i, k)
                out[count, 1] = max(i, k)
                count += 1
    return out[:count]


def sorted_unique(keys: np.ndarray) -> np.ndarray:
    """Sorted distinct values. (np.unique in numpy 2.x hashes int64 keys, which is several
    times slower than sorting for the tens of millions of keys of a 1M-particle garment.)"""
    keys = np.sort(keys)
    if keys.size:
        keys = keys[np.concatenate([[True], keys[1:] != keys[:-1]])]
    return keys


def _unique_pairs(pairs: np.ndarray, n: int, exclude_keys: np.ndarray) -> np.ndarray:
    keys = sorted_unique(topology.edge_keys(pairs, n))
    exclude = np.sort(exclude_keys)
    if exclude.size:
        at = np.minimum(np.searchsorted(exclude, keys), exclude.size - 1)
        keys = keys[exclude[at] != keys]
    return np.stack([keys // n, keys % n], axis=1)


def build_phases(
    pos: np.ndarray,
    counts: np.ndarray,
    indices: np.ndarray,
    adjacency: AdjacencyQuerier,
    hang_direction: np.ndarray,
    recover_quads: bool = True,
    shearing: bool = True,
    bending: bool = True,
) -> list[PhaseConstraints]:
    """Classify constraints into vertical, horizontal, shearing and bending phases.

    Phases come out in NvCloth's solve order (vertical, horizontal, shearing, bending);
    empty phases are left out. Pairs are (lo, hi) and sorted.
    """
    n = adjacency.particle_count
    quads = _quads_from_file(counts, indices)
    diagonal_edges = np.zeros(0, np.int64)
    if recover_quads:
        recovered, diagonal_edges = _recover_quads(pos, counts, indices, adjacency)
        quads = np.concatenate([quads, recovered])
    is_stretch = np.ones(adjacency.edge_count, bool)
    is_stretch[diagonal_edges] = False
    stretch = adjacency.edges[is_stretch]

    p = pos.astype(np.float64)
    hang = np.asarray(hang_direction, np.float64)
    hang = hang / np.linalg.norm(hang)
    d = p[stretch[:, 1]] - p[stretch[:, 0]]
    cos_to_hang = np.abs(d @ hang) / np.maximum(np.linalg.norm(d, axis=1), 1e-300)
    vertical = cos_to_hang >= np.cos(np.radians(VERTICAL_MAX_ANGLE_DEG))

    phases = [
        PhaseConstraints(PhaseType.VERTICAL, stretch[vertical]),
        PhaseConstraints(PhaseType.HORIZONTAL, stretch[~vertical]),
    ]
    stretch_keys = topology.edge_keys(stretch, n)
    shear = np.zeros((0, 2), np.int64)
    if shearing and quads.shape[0]:
        diagonals = np.concatenate([quads[:, [0, 2]], quads[:, [1, 3]]])
        shear = _unique_pairs(diagonals, n, stretch_keys)
        phases.append(PhaseConstraints(PhaseType.SHEARING, shear))
    if bending:
        rows = np.concatenate([stretch[:, 0], stretch[:, 1]])
        cols = np.concatenate([stretch[:, 1], stretch[:, 0]])
        order = np.lexsort((cols, rows))
        offsets, flat = csr_from_pairs(rows[order], cols[order], n)
        cos_limit = np.cos(np.radians(BENDING_MIN_ANGLE_DEG))
        pairs = _bending_pairs(offsets, flat, p, cos_limit)
        exclude = np.concatenate([stretch_keys, topology.edge_keys(shear, n)])
        phases.append(PhaseConstraints(PhaseType.BENDING, _unique_pairs(pairs, n, exclude)))
    return [phase for phase in phases if phase.pairs.shape[0]]
