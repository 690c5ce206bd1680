"""STL through meshio.

meshio.read() prints the error and calls sys.exit(1) on a ReadError, so the per-format
reader (meshio.stl.read) is called instead: it raises.
"""

from __future__ import annotations

import os
import struct

import numpy as np

from clothtool.io.meshin._common import _invalid, _meshio_polygons
from clothtool.mesh.clothmesh import ClothMesh


def read(source: str, prim: str | None) -> ClothMesh:
    """STL keeps every triangle's corners apart; meshio merges exactly equal corners (in order
    of first appearance), which is the only way STL describes a connected surface."""
    import meshio

    size = os.path.getsize(source)
    with open(source, "rb") as file:
        head = file.read(84)
    if not head.lstrip().startswith(b"solid") and len(head) == 84:
        (n_triangles,) = struct.unpack("<I", head[80:84])
        if size != 84 + 50 * n_triangles:
            need = f"{n_triangles} triangles need {84 + 50 * n_triangles} bytes"
            raise _invalid(source, f"truncated binary STL: {need}, the file has {size}")
    with np.errstate(over="ignore"):  # meshio's size check overflows uint32 on ASCII files
        mesh = meshio.stl.read(source)
    counts, indices = _meshio_polygons(mesh.cells)
    return ClothMesh(np.asarray(mesh.points).reshape(-1, 3), counts, indices, source=source)


READERS = {".stl": read}
