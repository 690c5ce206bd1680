"""Check a raw mesh and repair what can be repaired, before cooking.

Fatal problems raise MeshError with one line naming the file, the element and the fix.
Repairable problems are repaired and reported as warning lines; with ``strict=True`` the
first of them is raised as an error instead.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from clothtool.errors import MeshError
from clothtool.mesh import topology
from clothtool.mesh.clothmesh import ClothMesh

# Below this fraction of the squared bounding-box diagonal a triangle counts as zero-area.
ZERO_AREA_RELATIVE = 1e-12
# Triangles whose smallest angle is below this (degrees) are slivers: legal but ill-conditioned.
SLIVER_MIN_ANGLE_DEG = 1.0


def _listing(indices, limit: int = 5) -> str:
    indices = [int(i) for i in indices]
    shown = ", ".join(str(i) for i in indices[:limit])
    return shown + (f", ... ({len(indices)} in all)" if len(indices) > limit else "")


def bounding_box_diagonal(pos: np.ndarray) -> float:
    if pos.shape[0] == 0:
        return 0.0
    return float(np.linalg.norm(pos.max(axis=0).astype(np.float64) - pos.min(axis=0)))


class _Repairs:
    def __init__(self, source: str, strict: bool):
        self.source = source
        self.strict = strict
        self.lines: list[str] = []

    def add(self, what: str, fix: str) -> None:
        if self.strict:
            raise MeshError(f"{self.source}: {what}; {fix} (an error because of --strict)")
        self.lines.append(f"{self.source}: repaired: {what}")


def _check_fatal(mesh: ClothMesh) -> None:
    src = mesh.source
    n = mesh.vertex_count
    if n == 0 or mesh.face_count == 0:
        raise MeshError(f"{src}: mesh is empty ({n} vertices, {mesh.face_count} faces); export the garment as a polygon mesh")
    bad_count = np.flatnonzero(mesh.face_vertex_counts < 3)
    if bad_count.size:
        f = int(bad_count[0])
        raise MeshError(
            f"{src}: face {f} has {int(mesh.face_vertex_counts[f])} vertices; faces need at least 3, delete it in your DCC"
        )
    idx = mesh.face_vertex_indices
    bad = np.flatnonzero((idx < 0) | (idx >= n))
    if bad.size:
        face = int(topology.corner_face(mesh.face_vertex_counts)[bad[0]])
        raise MeshError(
            f"{src}: face {face} references vertex {int(idx[bad[0]])} but the mesh has {n} vertices (0..{n - 1}); re-export the mesh"
        )
    finite = np.isfinite(mesh.vertex_pos).all(axis=1)
    if not finite.all():
        v = int(np.flatnonzero(~finite)[0])
        raise MeshError(
            f"{src}: vertex {v} has a NaN or infinite coordinate {mesh.vertex_pos[v].tolist()}; fix or delete it in your DCC"
        )
    for name, values in mesh.vertex_attrs.items():
        ok = np.isfinite(values)
        if not ok.all():
            v = int(np.flatnonzero(~ok)[0])
            raise MeshError(f"{src}: vertex attribute '{name}' is NaN or infinite at vertex {v}; repaint it")
    if mesh.face_vertex_uv is not None and not np.isfinite(mesh.face_vertex_uv).all():
        corner = int(np.flatnonzero(~np.isfinite(mesh.face_vertex_uv).all(axis=1))[0])
        face = int(topology.corner_face(mesh.face_vertex_counts)[corner])
        raise MeshError(f"{src}: face {face} has a NaN UV; fix the UV layout in your DCC")


def _select_faces(mesh: ClothMesh, keep_faces: np.ndarray, corner_keep: np.ndarray | None = None) -> ClothMesh:
    """Keep faces where keep_faces is True (and, inside them, corners where corner_keep is)."""
    counts = mesh.face_vertex_counts
    corner_face = topology.corner_face(counts)
    keep_corner = keep_faces[corner_face]
    if corner_keep is not None:
        keep_corner &= corner_keep
    new_counts = np.bincount(corner_face[keep_corner], minlength=counts.shape[0])[keep_faces]
    uv = None if mesh.face_vertex_uv is None else mesh.face_vertex_uv[keep_corner]
    return mesh.replace(
        face_vertex_counts=new_counts,
        face_vertex_indices=mesh.face_vertex_indices[keep_corner],
        face_vertex_uv=uv,
    )


def _weld(mesh: ClothMesh, weld: float, diag: float) -> tuple[ClothMesh, np.ndarray]:
    remap, kept = topology.weld_map(mesh.vertex_pos, weld * diag)
    if kept.shape[0] == mesh.vertex_count:
        return mesh, remap
    # Welded vertices keep the position and paint of the lowest-index vertex of their cluster.
    welded = mesh.replace(
        vertex_pos=mesh.vertex_pos[kept],
        face_vertex_indices=remap[mesh.face_vertex_indices],
        vertex_attrs={k: v[kept] for k, v in mesh.vertex_attrs.items()},
    )
    return welded, remap


def _collapse_zero_length_edges(mesh: ClothMesh, repairs: _Repairs) -> ClothMesh:
    counts = mesh.face_vertex_counts
    idx = mesh.face_vertex_indices
    nxt = topology.next_corner(counts)
    repeated = idx == idx[nxt]
    if not repeated.any():
        return mesh
    faces = np.unique(topology.corner_face(counts)[repeated])
    repairs.add(
        f"faces {_listing(faces)} had zero-length edges (coincident vertices), collapsed",
        "weld the vertices in your DCC",
    )
    # drop a corner when it equals the next corner of its face; then drop faces left with < 3
    mesh = _select_faces(mesh, np.ones(counts.shape[0], bool), ~repeated)
    degenerate = mesh.face_vertex_counts < 3
    if degenerate.any():
        mesh = _select_faces(mesh, ~degenerate)
    # a face like (a, b, a, c) still repeats a vertex: it is degenerate, drop it
    corner_face = topology.corner_face(mesh.face_vertex_counts)
    keys = corner_face * np.int64(mesh.vertex_count) + mesh.face_vertex_indices
    order = np.argsort(keys, kind="stable")
    dup = np.zeros(keys.shape[0], bool)
    dup[order[1:]] = keys[order[1:]] == keys[order[:-1]]
    if dup.any():
        bad_faces = np.zeros(mesh.face_count, bool)
        bad_faces[corner_face[dup]] = True
        mesh = _select_faces(mesh, ~bad_faces)
    return mesh


def _drop_zero_area_faces(mesh: ClothMesh, diag: float, repairs: _Repairs) -> ClothMesh:
    tris, tri_face = topology.triangulate(mesh.face_vertex_counts, mesh.face_vertex_indices)
    area = np.bincount(tri_face, weights=topology.triangle_areas(mesh.vertex_pos, tris), minlength=mesh.face_count)
    zero = area <= ZERO_AREA_RELATIVE * diag * diag
    if not zero.any():
        return mesh
    repairs.add(f"faces {_listing(np.flatnonzero(zero))} have zero area, removed", "delete them in your DCC")
    return _select_faces(mesh, ~zero)


def _drop_duplicate_faces(mesh: ClothMesh, repairs: _Repairs) -> ClothMesh:
    counts = mesh.face_vertex_counts
    offsets = topology.face_offsets(counts)
    # canonical form of a face: its sorted vertex list, padded; faces of equal size compared.
    width = int(counts.max())
    padded = np.full((mesh.face_count, width), -1, np.int64)
    corner = np.arange(offsets[-1]) - np.repeat(offsets[:-1], counts)
    padded[topology.corner_face(counts), corner] = mesh.face_vertex_indices
    canon = np.sort(np.where(padded < 0, np.iinfo(np.int64).max, padded), axis=1)
    _, first, inverse = np.unique(canon, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    duplicate = first[inverse] != np.arange(mesh.face_count)
    if not duplicate.any():
        return mesh
    dups = np.flatnonzero(duplicate)
    repairs.add(
        f"faces {_listing(dups)} duplicate earlier faces (face {int(dups[0])} repeats face {int(first[inverse[dups[0]]])}), removed",
        "delete the duplicates in your DCC",
    )
    return _select_faces(mesh, ~duplicate)


def _drop_unreferenced_vertices(mesh: ClothMesh, repairs: _Repairs) -> tuple[ClothMesh, np.ndarray]:
    """Returns the mesh and the old -> new vertex index map (-1 for removed vertices)."""
    used = np.zeros(mesh.vertex_count, bool)
    used[mesh.face_vertex_indices] = True
    if used.all():
        return mesh, np.arange(mesh.vertex_count, dtype=np.int64)
    repairs.add(
        f"vertices {_listing(np.flatnonzero(~used))} belong to no face, removed",
        "delete the loose vertices in your DCC",
    )
    new_index = np.where(used, np.cumsum(used) - 1, -1)
    trimmed = mesh.replace(
        vertex_pos=mesh.vertex_pos[used],
        face_vertex_indices=new_index[mesh.face_vertex_indices],
        vertex_attrs={k: v[used] for k, v in mesh.vertex_attrs.items()},
    )
    return trimmed, new_index


def _check_manifold_and_orient(mesh: ClothMesh, repairs: _Repairs) -> ClothMesh:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    counts = mesh.face_vertex_counts
    half = topology.half_edges(counts, mesh.face_vertex_indices)
    edges, inverse = topology.unique_edges(half, mesh.vertex_count)
    uses = np.bincount(inverse, minlength=edges.shape[0])
    if uses.max() > 2:
        e = int(np.argmax(uses > 2))
        faces = topology.corner_face(counts)[inverse == e]
        raise MeshError(
            f"{mesh.source}: edge ({int(edges[e, 0])}, {int(edges[e, 1])}) is shared by {int(uses[e])} faces "
            f"({_listing(faces)}), a non-manifold edge; split it or delete the extra faces in your DCC"
        )
    # For each interior edge, the two faces agree on winding when they traverse it in
    # opposite directions.
    order = np.argsort(inverse, kind="stable")
    sorted_edges = inverse[order]
    pair_start = np.flatnonzero(np.diff(sorted_edges) == 0)
    if pair_start.size == 0:
        return mesh
    a, b = order[pair_start], order[pair_start + 1]
    face = topology.corner_face(counts)
    fa, fb = face[a], face[b]
    same_direction = half[a, 0] == half[b, 0]
    if not same_direction.any():
        return mesh
    # Orientation repair as parity labelling on the face graph: a face and its flipped copy
    # are two nodes; an edge traversed the same way joins a face to the other's flipped copy.
    # The labelling is impossible exactly when a face is connected to its own flipped copy.
    f = mesh.face_count
    src = np.concatenate([fa, fa + f])
    dst = np.concatenate([np.where(same_direction, fb + f, fb), np.where(same_direction, fb, fb + f)])
    graph = coo_matrix((np.ones(src.shape[0], np.int8), (src, dst)), shape=(2 * f, 2 * f))
    _, labels = connected_components(graph, directed=False)
    keep_label, flip_label = labels[:f], labels[f:]
    if np.any(keep_label == flip_label):
        face_id = int(np.flatnonzero(keep_label == flip_label)[0])
        raise MeshError(
            f"{mesh.source}: the surface around face {face_id} cannot be oriented consistently (a Moebius strip); "
            "cut it open in your DCC"
        )
    # Keep the orientation that most faces already have; on a tie, face order decides.
    votes = np.bincount(keep_label, minlength=2 * f)
    first_face = np.full(2 * f, f, np.int64)
    np.minimum.at(first_face, keep_label, np.arange(f))
    score = votes.astype(np.int64) * (f + 1) + (f - first_face)
    flip = score[flip_label] > score[keep_label]
    if not flip.any():
        return mesh
    repairs.add(
        f"faces {_listing(np.flatnonzero(flip))} were wound opposite to their neighbours, flipped",
        "unify the normals in your DCC",
    )
    return _reverse_faces(mesh, flip)


def _reverse_faces(mesh: ClothMesh, flip: np.ndarray) -> ClothMesh:
    counts = mesh.face_vertex_counts
    offsets = topology.face_offsets(counts)
    corner_face = topology.corner_face(counts)
    local = np.arange(offsets[-1]) - offsets[corner_face]
    # reversed winding keeps the first corner: (v0, v1, ..., vk) -> (v0, vk, ..., v1)
    reversed_local = np.where(local == 0, 0, counts[corner_face] - local)
    source = np.where(flip[corner_face], offsets[corner_face] + reversed_local, np.arange(offsets[-1]))
    uv = None if mesh.face_vertex_uv is None else mesh.face_vertex_uv[source]
    return mesh.replace(face_vertex_indices=mesh.face_vertex_indices[source], face_vertex_uv=uv)


def _warn_slivers(mesh: ClothMesh, repairs: _Repairs) -> None:
    tris, tri_face = topology.triangulate(mesh.face_vertex_counts, mesh.face_vertex_indices)
    sliver = topology.triangle_min_angles(mesh.vertex_pos, tris) < SLIVER_MIN_ANGLE_DEG
    if sliver.any():
        faces = np.unique(tri_face[sliver])
        what = f"faces {_listing(faces)} are slivers (an angle below {SLIVER_MIN_ANGLE_DEG} degree), kept"
        fix = "remesh them in your DCC: they make stiff, slow-converging constraints"
        if repairs.strict:
            raise MeshError(f"{mesh.source}: {what}; {fix} (an error because of --strict)")
        repairs.lines.append(f"{mesh.source}: warning: {what}; {fix}")


@dataclasses.dataclass(frozen=True)
class PreparedMesh:
    """A checked, welded and repaired mesh, ready to cook.

    Attributes:
        mesh: the clean mesh; its vertices are the fabric's particles.
        warnings: one line per kind of repair (empty for a clean input).
        vertex_map: i64 (file vertex count,) particle index of each vertex of the input
            file, -1 for vertices that were removed.
        welded: number of input vertices merged into others by welding.
    """

    mesh: ClothMesh
    warnings: list[str]
    vertex_map: np.ndarray
    welded: int


def prepare_mesh(mesh: ClothMesh, weld: float = 1e-6, strict: bool = False) -> PreparedMesh:
    """Validate ``mesh``, weld it, and repair what is repairable.

    ``weld`` is the welding tolerance relative to the bounding-box diagonal. Raises
    MeshError on fatal problems, and on any repair when ``strict``.
    """
    _check_fatal(mesh)
    repairs = _Repairs(mesh.source, strict)
    input_count = mesh.vertex_count
    referenced = np.zeros(mesh.vertex_count, bool)
    referenced[mesh.face_vertex_indices] = True
    diag = bounding_box_diagonal(mesh.vertex_pos[referenced])
    if diag == 0.0:
        raise MeshError(f"{mesh.source}: all vertices coincide; export the garment at its real size")
    mesh, vertex_map = _weld(mesh, weld, diag)
    welded = input_count - mesh.vertex_count
    mesh = _collapse_zero_length_edges(mesh, repairs)
    if mesh.face_count:
        mesh = _drop_zero_area_faces(mesh, diag, repairs)
    if mesh.face_count == 0:
        raise MeshError(f"{mesh.source}: no face is left after removing degenerate faces; export a real surface")
    mesh = _drop_duplicate_faces(mesh, repairs)
    mesh, trim_map = _drop_unreferenced_vertices(mesh, repairs)
    vertex_map = trim_map[vertex_map]
    mesh = _check_manifold_and_orient(mesh, repairs)
    _warn_slivers(mesh, repairs)
    return PreparedMesh(mesh, repairs.lines, vertex_map, welded)
