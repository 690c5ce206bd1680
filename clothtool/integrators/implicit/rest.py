"""The rest state of a cloth for Baraff & Witkin's energies, computed once per cloth.

Material space. Every particle of a triangle has material coordinates (u,v) that never
change; the map w(u,v) from material to world space is linear over the triangle, so its
gradient [w_u w_v] = [x1 - x0, x2 - x0] D^-1 with D = [[du1, du2], [dv1, dv2]] is constant.

We build D per triangle from the rest triangle itself, flattened into its own plane: the
corner coordinates are the rest edges projected on an orthonormal in-plane basis (t_u, t_v).
At rest w_u = t_u and w_v = t_v are then orthonormal, so the rest pose is exactly free of
stretch (|w_u| = |w_v| = 1 = b) and shear (w_u . w_v = 0), whatever the UV layout's scale,
seams or distortion. UVs only orient the basis: t_u is the direction in which u grows on the
rest triangle (the warp), t_v the in-plane perpendicular on the side where v grows (the weft).
Without UVs (or for a triangle with degenerate UVs) t_u is the world X axis projected on the
triangle's plane, or the Z axis where X is within 60 degrees of the normal.

Lengths are scene units: a stretch modulus in N/m applies unchanged (see ``solver``), a bend
modulus in N m is divided by (metres per unit)^2.

Bending. Each interior edge shared by two triangles is a hinge (wing a, wing b, edge start,
edge end); its condition is the dihedral angle minus the rest angle. The hinge weight
|e|^2 / (A_a + A_b) turns a bend modulus D into the hinge stiffness k = D |e|^2/(A_a + A_b):
with E = k/2 theta^2 a sheet rolled into a cylinder of curvature kappa then stores
D/2 kappa^2 per unit area (checked in tests/integrators/test_implicit_energies.py).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from clothtool.mesh.topology import face_offsets, triangulate

# the X axis is used as the warp direction unless it is within 60 degrees of the normal
_MIN_PROJECTED_AXIS = 0.5


@dataclasses.dataclass(frozen=True, eq=False)
class RestShape:
    """Per-element rest data (t triangles, p hinges), float64 unless noted.

    triangles: i32 (t,3).
    tri_dinv: (t,4) D^-1 row-major (d00, d01, d10, d11): w_u = e1 d00 + e2 d10,
        w_v = e1 d01 + e2 d11 with e1 = x1 - x0, e2 = x2 - x0. Zero for degenerate triangles.
    tri_area: (t,) rest area in scene units^2 (0 for degenerate triangles, which are skipped).
    hinges: i32 (p,4) wing a, wing b, edge start, edge end.
    hinge_rest_angle: (p,) rest dihedral angle in radians.
    hinge_weight: (p,) |e|^2 / (A_a + A_b), dimensionless.
    """

    triangles: np.ndarray
    tri_dinv: np.ndarray
    tri_area: np.ndarray
    hinges: np.ndarray
    hinge_rest_angle: np.ndarray
    hinge_weight: np.ndarray

    @property
    def triangle_count(self) -> int:
        return int(self.triangles.shape[0])

    @property
    def hinge_count(self) -> int:
        return int(self.hinges.shape[0])


def build_rest_shape(rest_pos: np.ndarray, triangles: np.ndarray, corner_uv: np.ndarray | None = None) -> RestShape:
    """The rest shape of ``triangles`` over ``rest_pos`` (n,3); ``corner_uv`` (t,3,2) orients
    the warp per triangle (see ``triangle_corner_uvs``)."""
    pos = np.asarray(rest_pos, np.float64)
    tris = np.ascontiguousarray(triangles, np.int32)
    dinv, area = material_frames(pos, tris, corner_uv)
    hinges = bend_hinges(tris, pos.shape[0])
    return RestShape(
        triangles=tris,
        tri_dinv=dinv,
        tri_area=area,
        hinges=hinges,
        hinge_rest_angle=dihedral_angles(pos, hinges),
        hinge_weight=hinge_weights(pos, hinges),
    )


def triangle_corner_uvs(fabric) -> np.ndarray | None:
    """(t,3,2) UVs of each triangle's corners, from the fabric's per-face-vertex UVs.

    The fabric's triangles are the fan triangulation of its faces; None when the fabric has
    no UVs or its triangles are not that triangulation (a hand-built fabric)."""
    uv = fabric.face_vertex_uv
    if uv.shape[0] == 0 or uv.shape[0] != fabric.face_vertex_indices.shape[0]:
        return None
    counts, indices = fabric.face_vertex_counts, fabric.face_vertex_indices
    fan, tri_face = triangulate(counts, indices)
    if fan.shape != fabric.triangles.shape or not np.array_equal(fan, fabric.triangles):
        return None
    base = face_offsets(counts)[tri_face]
    first = np.concatenate([[0], np.cumsum(np.maximum(counts.astype(np.int64) - 2, 0))])[tri_face]
    local = np.arange(fan.shape[0]) - first
    corners = np.stack([base, base + local + 1, base + local + 2], axis=1)
    return uv.astype(np.float64)[corners]


def _unit(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    length = np.linalg.norm(v, axis=-1)
    return v / np.maximum(length, 1e-300)[..., None], length


def material_frames(pos: np.ndarray, triangles: np.ndarray, corner_uv: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """(D^-1 as (t,4), rest area (t,)) per triangle; see the module docstring."""
    p0, p1, p2 = (pos[triangles[:, k]] for k in range(3))
    e1, e2 = p1 - p0, p2 - p0
    normal, double_area = _unit(np.cross(e1, e2))
    scale = np.maximum(np.linalg.norm(e1, axis=1), np.linalg.norm(e2, axis=1))
    valid = double_area > 1e-12 * np.maximum(scale * scale, 1e-300)

    def in_plane(direction):
        return direction - np.sum(direction * normal, axis=1, keepdims=True) * normal

    tangent_u = in_plane(np.broadcast_to([1.0, 0.0, 0.0], normal.shape))
    short = np.linalg.norm(tangent_u, axis=1) < _MIN_PROJECTED_AXIS
    tangent_u[short] = in_plane(np.broadcast_to([0.0, 0.0, 1.0], normal.shape))[short]
    tangent_v_hint = np.cross(normal, tangent_u)
    if corner_uv is not None:
        duv1 = corner_uv[:, 1] - corner_uv[:, 0]
        duv2 = corner_uv[:, 2] - corner_uv[:, 0]
        det = duv1[:, 0] * duv2[:, 1] - duv2[:, 0] * duv1[:, 1]
        uv_scale = np.maximum(np.abs(duv1).max(axis=1), np.abs(duv2).max(axis=1))
        good = np.abs(det) > 1e-9 * np.maximum(uv_scale * uv_scale, 1e-300)
        safe = np.where(good, det, 1.0)[:, None]
        # [e1 e2] = [T_u T_v] [[du1, du2], [dv1, dv2]]  ->  T_u, T_v: world tangents of u and v
        d_du = (e1 * duv2[:, 1:2] - e2 * duv1[:, 1:2]) / safe
        d_dv = (e2 * duv1[:, 0:1] - e1 * duv2[:, 0:1]) / safe
        good &= np.linalg.norm(in_plane(d_du), axis=1) > 0
        tangent_u[good] = in_plane(d_du)[good]
        tangent_v_hint[good] = d_dv[good]
    tangent_u, _ = _unit(tangent_u)
    tangent_v = np.cross(normal, tangent_u)
    flip = np.sum(tangent_v * tangent_v_hint, axis=1) < 0
    tangent_v[flip] *= -1.0
    du1 = np.sum(e1 * tangent_u, axis=1)
    dv1 = np.sum(e1 * tangent_v, axis=1)
    du2 = np.sum(e2 * tangent_u, axis=1)
    dv2 = np.sum(e2 * tangent_v, axis=1)
    det = du1 * dv2 - du2 * dv1
    det = np.where(valid, det, 1.0)
    dinv = np.stack([dv2, -du2, -dv1, du1], axis=1) / det[:, None]
    dinv[~valid] = 0.0
    area = np.where(valid, 0.5 * double_area, 0.0)
    return np.ascontiguousarray(dinv), area


def bend_hinges(triangles: np.ndarray, particle_count: int) -> np.ndarray:
    """i32 (p,4) (wing a, wing b, edge start, edge end) for every edge shared by exactly two
    triangles, in the order of the edges' keys."""
    t = triangles.astype(np.int64)
    starts = t.reshape(-1)
    ends = t[:, [1, 2, 0]].reshape(-1)
    wings = t[:, [2, 0, 1]].reshape(-1)
    lo, hi = np.minimum(starts, ends), np.maximum(starts, ends)
    keys = lo * np.int64(particle_count) + hi
    order = np.argsort(keys, kind="stable")
    keys = keys[order]
    if keys.size == 0:
        return np.zeros((0, 4), np.int32)
    new_run = np.concatenate([[True], keys[1:] != keys[:-1]])
    run_start = np.flatnonzero(new_run)
    run_length = np.diff(np.concatenate([run_start, [keys.size]]))
    pair = run_start[run_length == 2]
    first, second = order[pair], order[pair + 1]
    hinges = np.stack([wings[first], wings[second], starts[first], ends[first]], axis=1)
    return np.ascontiguousarray(hinges, np.int32)


def dihedral_angles(pos: np.ndarray, hinges: np.ndarray) -> np.ndarray:
    """(p,) signed dihedral angle of each hinge: atan2((n_a x n_b) . e, n_a . n_b) with
    n_a = (x_a - x_s) x (x_a - x_e), n_b = (x_b - x_e) x (x_b - x_s), e = x_e - x_s
    (0 for a flat hinge)."""
    x = np.asarray(pos, np.float64)
    xa, xb, xs, xe = (x[hinges[:, k]] for k in range(4))
    na, _ = _unit(np.cross(xa - xs, xa - xe))
    nb, _ = _unit(np.cross(xb - xe, xb - xs))
    e, _ = _unit(xe - xs)
    return np.arctan2(np.sum(np.cross(na, nb) * e, axis=1), np.sum(na * nb, axis=1))


def hinge_weights(pos: np.ndarray, hinges: np.ndarray) -> np.ndarray:
    """(p,) |e|^2 / (A_a + A_b) at ``pos`` (0 where both triangles are degenerate)."""
    x = np.asarray(pos, np.float64)
    xa, xb, xs, xe = (x[hinges[:, k]] for k in range(4))
    area = 0.5 * (np.linalg.norm(np.cross(xa - xs, xa - xe), axis=1) + np.linalg.norm(np.cross(xb - xe, xb - xs), axis=1))
    edge2 = np.sum((xe - xs) ** 2, axis=1)
    return np.where(area > 0, edge2 / np.where(area > 0, area, 1.0), 0.0)
