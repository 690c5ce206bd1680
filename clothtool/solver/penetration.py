"""How deep a cloth's faces sink into its colliders (a measurement: compiled kernels for spheres
and capsules, clothtool.solver.kernels.penetration_shapes, and for triangle meshes,
clothtool.solver.kernels.penetration_mesh).

Particles can all stay outside a collider while the faces between them sink into it: a
capsule thinner than the cloth's edges slips between two particles. This measures the faces:
for every cloth triangle and every sphere or capsule (a round cone between two spheres) the
deepest point of the triangle inside the collider, i.e. minus the minimum over the triangle
of the collider's signed distance, found exactly (the candidates of the face collision's
deepest-point search, every one scored). The collider's surface includes its own thickness
(margin); the cloth's thickness is not subtracted: a face whose depth exceeds the cloth's
thickness is "beyond the thickness". Triangles far from every collider (bounding spheres
outside) are skipped. ``round_cone_distance`` and ``barycentric_grid`` (numpy) are for
figures and tests that sample faces themselves.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from clothtool.collision.colliders import ColliderArrays
from clothtool.solver.kernels.collide_shapes import CAPSULE_COLUMNS
from clothtool.solver.kernels.penetration_shapes import round_cone_depths


@dataclasses.dataclass(frozen=True)
class FacePenetration:
    """depth: the deepest face point inside a collider in metres (<= 0 when no face is inside
    any: minus the smallest clearance, or -inf when no face is near a collider);
    faces_beyond: how many triangles sink deeper than the cloth's thickness."""

    depth: float
    faces_beyond: int


def barycentric_grid(level: int) -> np.ndarray:
    """(k,3) float64 barycentric points (i, j, level - i - j) / level, corners and edges included."""
    i, j = np.meshgrid(np.arange(level + 1), np.arange(level + 1), indexing="ij")
    keep = i + j <= level
    i, j = i[keep], j[keep]
    return np.stack([i, j, level - i - j], axis=1).astype(np.float64) / level


def _dot(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Dot products over the last axis, broadcast (einsum: numpy's reductions over an axis of
    three are several times slower)."""
    x, y = np.broadcast_arrays(x, y)
    return np.einsum("...i,...i->...", x, y)


def round_cone_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, ra: np.ndarray, rb: np.ndarray) -> np.ndarray:
    """Signed distance (negative inside) of points p (..., 3) to the convex hull of the spheres
    (a, ra) and (b, rb), each broadcast against p's leading axes (the exact round cone distance;
    the bigger sphere when a == b or one sphere holds the other)."""
    ba = b - a
    l2 = _dot(ba, ba)
    # one sphere holds the other (the cone formula then measures a hull that is not there)
    held = np.sqrt(l2) <= np.abs(ra - rb)
    a, ra = np.where(held[..., None] & (rb > ra)[..., None], b, a), np.where(held & (rb > ra), rb, ra)
    degenerate = (l2 <= 1e-30) | held
    l2 = np.where(degenerate, 1.0, l2)
    rr = ra - rb
    a2 = l2 - rr * rr
    pa = p - a
    y = _dot(pa, ba)
    z = y - l2
    w = pa * l2[..., None] - ba * y[..., None]
    x2 = _dot(w, w)
    y2 = y * y * l2
    z2 = z * z * l2
    k = np.sign(rr) * rr * rr * x2
    near_b = np.sign(z) * a2 * z2 > k
    near_a = np.sign(y) * a2 * y2 < k
    side = (np.sqrt(np.maximum(x2 * a2 / l2, 0.0)) + y * rr) / l2 - ra
    distance = np.where(near_b, np.sqrt(x2 + z2) / l2 - rb, np.where(near_a, np.sqrt(x2 + y2) / l2 - ra, side))
    sphere = np.sqrt(_dot(pa, pa)) - ra
    return np.where(degenerate, sphere, distance)


def _cone_records(worlds: np.ndarray, colliders: ColliderArrays) -> np.ndarray:
    """(..., q, CAPSULE_COLUMNS) float64 capsule records (ends and radii in columns 8-15) of
    every sphere collider (both ends alike) and capsule of ``colliders``, radii grown by the
    collider's margin, from (..., s, 4) float64 sphere ``worlds`` (centre, radius): one
    ColliderArrays' spheres, or every row of a bake's prefetched ones."""
    spheres = np.flatnonzero(colliders.sphere_is_collider)
    ends = colliders.capsule_spheres
    first, second = np.concatenate([spheres, ends[:, 0]]), np.concatenate([spheres, ends[:, 1]])
    margin = np.concatenate([colliders.sphere_margin[spheres], colliders.capsule_margin]).astype(np.float64)
    cones = np.zeros((*worlds.shape[:-2], first.shape[0], CAPSULE_COLUMNS))
    cones[..., 8:11], cones[..., 11] = worlds[..., first, :3], worlds[..., first, 3] + margin
    cones[..., 12:15], cones[..., 15] = worlds[..., second, :3], worlds[..., second, 3] + margin
    return cones


class ConeRecords:
    """The round cones (``_cone_records``) of the colliders one cloth's faces are measured
    against, frame after frame (a callable: ColliderArrays -> records). A scene whose colliders
    stand gives the same ColliderArrays every frame: its records are kept. A bake's prefetched
    colliders are rows of one stack (ColliderArrays.source): the records of every row are
    made at once, and a frame takes its row. Made anew each frame, the records were ~13 us
    of numpy calls, a third of a small garment's measure. round_cone_depths fills their axis
    columns (17-23) in place: the same values at every call."""

    def __init__(self):
        self._last: tuple | None = None  # (colliders, their records)
        self._stack: tuple | None = None  # (prefetched samples, (T, q, CAPSULE_COLUMNS) records)

    def __call__(self, colliders: ColliderArrays) -> np.ndarray:
        if self._last is not None and self._last[0] is colliders:
            return self._last[1]
        if colliders.source is None:
            worlds = np.concatenate([colliders.sphere_center, colliders.sphere_radius[:, None]], axis=1)
            records = _cone_records(worlds.astype(np.float64), colliders)
        else:
            samples, row = colliders.source
            if self._stack is None or self._stack[0] is not samples:
                self._stack = (samples, _cone_records(samples.sphere_worlds(np.float64), colliders))
            records = self._stack[1][row]
        self._last = (colliders, records)
        return records


def _round_cone_depths(points: np.ndarray, triangles: np.ndarray, cones: np.ndarray) -> np.ndarray:
    """(t,) float64: how deep each triangle reaches into the round cones (-inf: near none)."""
    depth_per_triangle = np.full(triangles.shape[0], -np.inf)
    if cones.shape[0] and triangles.shape[0]:
        round_cone_depths(points, np.ascontiguousarray(triangles, np.int32), cones, depth_per_triangle)
    return depth_per_triangle


def closed_meshes(points: np.ndarray, triangles: np.ndarray, triangle_mesh: np.ndarray, meshes: int) -> np.ndarray:
    """bool (meshes,): whether every edge of each mesh has exactly two triangles, vertices at
    the same position counting as one (a box exported face by face is closed)."""
    closed = np.ones(meshes, bool)
    if triangles.shape[0] == 0:
        return closed
    _, welded = np.unique(points, axis=0, return_inverse=True)
    triangles = welded.reshape(-1)[triangles]
    edges = np.sort(np.stack([triangles, np.roll(triangles, -1, axis=1)], axis=-1), axis=-1).reshape(-1, 2)
    owner = np.repeat(triangle_mesh, 3)
    keys, counts = np.unique(np.column_stack([owner, edges]), axis=0, return_counts=True)
    closed[np.unique(keys[counts != 2, 0])] = False
    return closed


def mesh_depths(points: np.ndarray, triangles: np.ndarray, colliders: ColliderArrays) -> np.ndarray:
    """(t,) float64: how deep each triangle reaches into the mesh colliders, grown by their
    margins (clothtool.solver.kernels.penetration_mesh; -inf: near none)."""
    depth_per_triangle = np.full(triangles.shape[0], -np.inf)
    mesh_triangles = np.ascontiguousarray(colliders.mesh_triangles, np.int32)
    if mesh_triangles.shape[0] == 0 or triangles.shape[0] == 0:
        return depth_per_triangle
    from clothtool.solver.kernels.collide_mesh import grid_cell_ranges, grid_fill, grid_layout, triangle_bounds
    from clothtool.solver.kernels.penetration_mesh import face_depths, inside_depths

    order = np.argsort(colliders.triangle_mesh, kind="stable")
    mesh_triangles = np.ascontiguousarray(mesh_triangles[order])
    owner = colliders.triangle_mesh[order]
    meshes = colliders.mesh_margin.shape[0]
    first = np.searchsorted(owner, np.arange(meshes + 1)).astype(np.int64)
    mesh_margin = colliders.mesh_margin.astype(np.float64)
    mesh_points = np.ascontiguousarray(colliders.mesh_points, np.float64)
    corner_depth = np.empty(points.shape[0])
    inside_depths(points, mesh_points, mesh_triangles, first, closed_meshes(mesh_points, mesh_triangles, owner, meshes), mesh_margin, corner_depth)
    margins = np.ascontiguousarray(mesh_margin[owner])
    t = mesh_triangles.shape[0]
    bounds = np.empty((t, 6))
    triangle_bounds(mesh_points, mesh_points, mesh_triangles, margins, 0.0, bounds)
    grid = np.empty(7)
    cells = grid_layout(bounds, 16.0 * t, grid)
    cell_ranges = np.empty((t, 6), np.int32)
    entries = grid_cell_ranges(bounds, grid, cell_ranges)
    cell_start = np.empty(cells + 1, np.int32)
    cell_items = np.empty(max(entries, 1), np.int32)
    grid_fill(cell_ranges, grid, cell_start, cell_items)
    face_depths(
        points, np.ascontiguousarray(triangles, np.int32), corner_depth, mesh_points, mesh_triangles, margins, cell_start,
        cell_items, cell_ranges, grid, depth_per_triangle,
    )
    return depth_per_triangle


def warm_up_mesh_depths() -> None:
    """Compile mesh_depths' kernels (a bake times this as "jit warm-up", not as its first
    frame's stats) on a tetrahedron and one triangle: the types a bake passes."""
    tetrahedron = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.int32)
    colliders = ColliderArrays(
        mesh_points=tetrahedron, mesh_triangles=faces, triangle_mesh=np.zeros(4, np.int32),
        mesh_margin=np.full(1, 0.01, np.float32), mesh_friction=np.zeros(1, np.float32),
    )
    mesh_depths(np.array([[0.2, 0.2, 0.2], [2, 0, 0], [0, 2, 0]], np.float64), faces[:1], colliders)


def warm_up_round_cone_depths() -> None:
    """Compile the spheres' and capsules' measure (round_cone_depths) for the types a bake passes."""
    triangle = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1]], np.float64)
    cones = np.zeros((0, CAPSULE_COLUMNS))
    round_cone_depths(triangle, np.array([[0, 1, 2]], np.int32), cones, np.full(1, -np.inf))


def face_penetration(
    points: np.ndarray, triangles: np.ndarray, colliders: ColliderArrays, meters_per_unit: float, thickness_m: float,
    cones: ConeRecords | None = None,
) -> FacePenetration:
    """The faces' penetration of ``colliders`` (same space and scene units as ``points``):
    spheres and capsules as in the module docstring, mesh colliders as in
    clothtool.solver.kernels.penetration_mesh.

    points: (n,3) cloth positions; triangles: i32 (t,3); thickness_m: the cloth's thickness in
    metres (the threshold of ``faces_beyond``); cones: the ConeRecords a cloth measured with
    last frame (its colliders' records, kept from frame to frame).
    """
    if triangles.shape[0] == 0:
        return FacePenetration(-np.inf, 0)
    p = np.ascontiguousarray(points, np.float64)
    depth_per_triangle = _round_cone_depths(p, triangles, (ConeRecords() if cones is None else cones)(colliders))
    if colliders.mesh_triangles.shape[0]:
        depth_per_triangle = np.maximum(depth_per_triangle, mesh_depths(p, triangles, colliders))
    depth = float(depth_per_triangle.max()) * meters_per_unit
    return FacePenetration(depth, int(np.count_nonzero(depth_per_triangle * meters_per_unit > thickness_m)))
