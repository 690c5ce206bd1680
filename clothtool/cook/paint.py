"""Pins and painted maps: which particles are pinned, motion-constraint radii, stiffness.

Artists paint these in the DCC as per-vertex attributes (or give a box, or a list of vertex
indices). Values are plain numbers: nothing here evaluates user expressions.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from clothtool.errors import MeshError
from clothtool.inputs import note_input
from clothtool.mesh.clothmesh import ClothMesh


def _attribute(mesh: ClothMesh, name: str, option: str) -> np.ndarray:
    if name not in mesh.vertex_attrs:
        available = ", ".join(sorted(mesh.vertex_attrs)) or "none"
        raise MeshError(
            f"{mesh.source}: {option} names vertex attribute '{name}', which the mesh does not have "
            f"(attributes: {available}); paint it or pick one of those"
        )
    return mesh.vertex_attrs[name].astype(np.float64)


def _unit_interval(mesh: ClothMesh, name: str, values: np.ndarray, option: str) -> np.ndarray:
    bad = np.flatnonzero((values < 0) | (values > 1))
    if bad.size:
        v = int(bad[0])
        raise MeshError(
            f"{mesh.source}: {option} attribute '{name}' is {values[v]:g} at vertex {v}; "
            "weights must lie in [0, 1], repaint or rescale it"
        )
    return values


def pin_mask_from_attribute(mesh: ClothMesh, name: str, threshold: float) -> np.ndarray:
    """Pinned where the painted weight reaches ``threshold`` (weights in [0, 1])."""
    values = _unit_interval(mesh, name, _attribute(mesh, name, "--pin-attr"), "--pin-attr")
    return values >= threshold


def pin_mask_from_box(pos: np.ndarray, box: tuple[float, ...]) -> np.ndarray:
    """Pinned where the particle lies inside the axis-aligned box (xmin,ymin,zmin,xmax,ymax,zmax)."""
    lo, hi = np.asarray(box[:3], np.float64), np.asarray(box[3:], np.float64)
    return np.all((pos >= lo) & (pos <= hi), axis=1)


def read_index_file(path: str | Path) -> np.ndarray:
    """Vertex indices from a text file: integers separated by whitespace or commas, '#' comments."""
    path = Path(path)
    note_input(path)
    if not path.is_file():
        raise MeshError(f"{path}: pin index file not found; check the path given to --pin-file")
    numbers = []
    for line_no, line in enumerate(path.read_text(errors="replace").splitlines(), start=1):
        for token in line.split("#", 1)[0].replace(",", " ").split():
            try:
                numbers.append(int(token))
            except ValueError:
                raise MeshError(
                    f"{path}: line {line_no}: '{token}' is not a vertex index; list integers separated by spaces or commas"
                ) from None
    return np.asarray(numbers, np.int64)


def pin_mask_from_indices(
    indices: np.ndarray, vertex_map: np.ndarray, source: str, particle_count: int
) -> np.ndarray:
    """Pinned particles from indices into the *file's* vertices (mapped through welding)."""
    bad = np.flatnonzero((indices < 0) | (indices >= vertex_map.shape[0]))
    if bad.size:
        raise MeshError(
            f"{source}: --pin-file lists vertex {int(indices[bad[0]])} but the mesh file has "
            f"{vertex_map.shape[0]} vertices; fix the index list"
        )
    mask = np.zeros(particle_count, bool)
    mapped = vertex_map[indices]
    mask[mapped[mapped >= 0]] = True
    return mask


def max_distance_from_attribute(mesh: ClothMesh, name: str, low: float, high: float) -> np.ndarray:
    """Motion-constraint radius per particle: low + weight * (high - low), weights in [0, 1].

    This is the convention of game-engine cloth painting: 0 paints "stays at the animated
    pose" (with low = 0, the particle is pinned at run time), 1 paints the largest freedom.
    """
    if low < 0 or high < low:
        raise MeshError(f"{mesh.source}: --max-distance-range {low:g},{high:g} must satisfy 0 <= low <= high")
    weights = _unit_interval(mesh, name, _attribute(mesh, name, "--max-distance-attr"), "--max-distance-attr")
    return (low + weights * (high - low)).astype(np.float32)


def stiffness_from_attribute(mesh: ClothMesh, name: str) -> np.ndarray:
    """Per-particle stiffness multiplier in [0, 1]."""
    return _unit_interval(mesh, name, _attribute(mesh, name, "--stiffness-attr"), "--stiffness-attr")
