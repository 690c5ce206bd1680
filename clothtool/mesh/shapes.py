"""Procedural cloth shapes: rectangular grids (for tests, benchmarks and scene generators)."""

from __future__ import annotations

import numpy as np

from clothtool.mesh.clothmesh import ClothMesh


def grid(
    columns: int,
    rows: int,
    spacing: float = 1.0,
    quads: bool = False,
    plane: str = "XY",
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> ClothMesh:
    """A ``columns`` x ``rows`` grid of particles, row 0 at the top.

    In plane "XY" the grid hangs down from ``origin`` (columns along +X, rows along -Y); in
    plane "XZ" it lies flat (columns along +X, rows along +Z) with its normal along +Y.
    Faces are quads, or two triangles per quad split along the (top-left, bottom-right)
    diagonal. UVs run from (0,1) at the top left to (1,0) at the bottom right.
    """
    if columns < 2 or rows < 2:
        raise ValueError("a grid needs at least 2 columns and 2 rows")
    i, j = np.meshgrid(np.arange(columns), np.arange(rows))
    x = i.ravel() * spacing
    d = j.ravel() * spacing
    if plane == "XY":
        pos = np.stack([x, -d, np.zeros_like(x)], axis=1)
    elif plane == "XZ":
        pos = np.stack([x, np.zeros_like(x), d], axis=1)
    else:
        raise ValueError("plane must be 'XY' or 'XZ'")
    pos = pos + np.asarray(origin)
    index = np.arange(columns * rows).reshape(rows, columns)
    a, b = index[:-1, :-1].ravel(), index[:-1, 1:].ravel()
    c, e = index[1:, 1:].ravel(), index[1:, :-1].ravel()
    uv_of = np.stack([i.ravel() / (columns - 1), 1.0 - j.ravel() / (rows - 1)], axis=1)
    if quads:
        faces = np.stack([a, e, c, b], axis=1)
    else:
        faces = np.concatenate([np.stack([a, e, c], axis=1), np.stack([a, c, b], axis=1)])
    counts = np.full(faces.shape[0], faces.shape[1], np.int32)
    return ClothMesh(
        vertex_pos=pos,
        face_vertex_counts=counts,
        face_vertex_indices=faces.reshape(-1),
        face_vertex_uv=uv_of[faces.reshape(-1)],
        source=f"<grid {columns}x{rows}>",
    )
