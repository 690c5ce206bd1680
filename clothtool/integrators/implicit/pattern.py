"""The fixed sparsity pattern of the implicit system, the element colouring and the edges.

The system matrix A = M - h df/dv - h^2 df/dx couples two particles exactly when they share a
triangle or a bending hinge; that never changes, so the pattern is built once per cloth as a
block CSR matrix of 3x3 blocks (scipy's BSR layout: ``row_offsets``, ``columns``, values
(nnzb,3,3)), and every element knows the block slots its local Jacobian blocks add to.
Assembly then only fills values.

Elements are coloured greedily so that no two elements of one colour share a particle: each
colour is assembled in parallel without write conflicts, and the result does not depend on
the number of threads.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from clothtool.integrators.implicit.kernels.implicit_coloring import greedy_colors


@dataclasses.dataclass(frozen=True, eq=False)
class BlockPattern:
    """row_offsets i32 (n+1,), columns i32 (nnzb,): block CSR, columns sorted per row;
    diagonal_slot i32 (n,); triangle_slot i32 (t,9) and hinge_slot i32 (p,16): the slot of
    block (a,b) of an element's corners at [a * corners + b]."""

    row_offsets: np.ndarray
    columns: np.ndarray
    diagonal_slot: np.ndarray
    triangle_slot: np.ndarray
    hinge_slot: np.ndarray

    @property
    def block_count(self) -> int:
        return int(self.columns.shape[0])

    def empty_values(self) -> np.ndarray:
        return np.zeros((self.block_count, 3, 3), np.float64)


def _element_pairs(elements: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    corners = elements.shape[1]
    rows = np.repeat(elements, corners, axis=1).reshape(-1).astype(np.int64)
    cols = np.tile(elements, (1, corners)).reshape(-1).astype(np.int64)
    return rows, cols


def build_pattern(particle_count: int, triangles: np.ndarray, hinges: np.ndarray) -> BlockPattern:
    n = np.int64(particle_count)
    tri_rows, tri_cols = _element_pairs(triangles)
    hinge_rows, hinge_cols = _element_pairs(hinges)
    diagonal = np.arange(n, dtype=np.int64)
    keys = np.concatenate([tri_rows * n + tri_cols, hinge_rows * n + hinge_cols, diagonal * n + diagonal])
    unique = np.unique(keys)
    rows, columns = unique // n, unique % n
    row_offsets = np.zeros(particle_count + 1, np.int64)
    np.cumsum(np.bincount(rows, minlength=particle_count), out=row_offsets[1:])

    def slots(r, c):
        return np.searchsorted(unique, r * n + c).astype(np.int32)

    return BlockPattern(
        row_offsets=row_offsets.astype(np.int32),
        columns=columns.astype(np.int32),
        diagonal_slot=slots(diagonal, diagonal),
        triangle_slot=slots(tri_rows, tri_cols).reshape(-1, 9),
        hinge_slot=slots(hinge_rows, hinge_cols).reshape(-1, 16),
    )


def color_elements(elements: np.ndarray, particle_count: int) -> tuple[np.ndarray, np.ndarray]:
    """(order i32 (e,), offsets i32 (colours+1,)): elements[order[offsets[k]:offsets[k+1]]]
    share no particle. Greedy in element order, so the result is deterministic."""
    elements = np.ascontiguousarray(elements, np.int32)
    colors = np.empty(elements.shape[0], np.int64)
    count = greedy_colors(elements, particle_count, colors) if elements.shape[0] else 0
    order = np.argsort(colors, kind="stable").astype(np.int32)
    offsets = np.zeros(count + 1, np.int64)
    np.cumsum(np.bincount(colors, minlength=count), out=offsets[1:])
    return order, offsets.astype(np.int32)


def triangle_edges(triangles: np.ndarray, particle_count: int) -> np.ndarray:
    """i32 (e,2) the unique edges of the triangles, lower index first, sorted."""
    t = triangles.astype(np.int64)
    pairs = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    pairs.sort(axis=1)
    keys = np.unique(pairs[:, 0] * np.int64(particle_count) + pairs[:, 1])
    return np.stack([keys // particle_count, keys % particle_count], axis=1).astype(np.int32)
