"""Colliders as values: the flat float32 arrays the collision stages see (ColliderArrays)
and the shape description a cache stores (ColliderInfo). The scene builds both; the solvers
and the cache writers read them (a neutral module: it imports no scene, solver or io code).

A scene's colliders at one instant are flattened per primitive kind (NvCloth's layout):
spheres; capsules as pairs of spheres joined by a tapered cone; convexes as sets of planes
(a plane collider is a convex of one plane); triangle meshes as points and triangles. The
bake samples them at the start and end of each frame; collision interpolates linearly
between the two across the frame's iterations (NvCloth's start/target scheme), so a
collider never teleports between iterations.

All positions are world space, scene units. Each primitive carries its margin (collider
thickness; the cloth's thickness is added by the stage) and friction coefficient; a NaN
friction means "the colliding cloth's material friction" (see ``friction_or``).
"""

from __future__ import annotations

import dataclasses

import numpy as np


def _f32(shape) -> np.ndarray:
    return np.zeros(shape, np.float32)


def _i32(shape) -> np.ndarray:
    return np.zeros(shape, np.int32)


@dataclasses.dataclass(frozen=True, eq=False)
class ColliderArrays:
    """Attributes (s spheres, c capsules, p planes, k convexes, m mesh points, t triangles):

    sphere_center f32 (s,3), sphere_radius f32 (s,): spheres, including capsule ends.
    sphere_margin f32 (s,), sphere_friction f32 (s,): for spheres that are colliders on
        their own; ``sphere_is_collider`` bool (s,) is False for capsule-only ends.
    capsule_spheres i32 (c,2): the two end spheres of each capsule (radii may differ).
    capsule_margin f32 (c,), capsule_friction f32 (c,).
    plane f32 (p,4): (nx, ny, nz, d) with unit outward normal n: the solid side is
        n . x < d, particles are pushed to n . x >= d + margin.
    convex_plane_offsets i32 (k+1,): convex j is the intersection of the solid sides of
        planes [offsets[j], offsets[j+1]).
    convex_margin f32 (k,), convex_friction f32 (k,).
    mesh_points f32 (m,3), mesh_triangles i32 (t,3): all mesh colliders' triangles
        (outward normals by counter-clockwise winding), ``triangle_mesh`` i32 (t,) which
        mesh each belongs to, mesh_margin f32 (meshes,), mesh_friction f32 (meshes,).
    """

    sphere_center: np.ndarray = dataclasses.field(default_factory=lambda: _f32((0, 3)))
    sphere_radius: np.ndarray = dataclasses.field(default_factory=lambda: _f32(0))
    sphere_margin: np.ndarray = dataclasses.field(default_factory=lambda: _f32(0))
    sphere_friction: np.ndarray = dataclasses.field(default_factory=lambda: _f32(0))
    sphere_is_collider: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, bool))
    capsule_spheres: np.ndarray = dataclasses.field(default_factory=lambda: _i32((0, 2)))
    capsule_margin: np.ndarray = dataclasses.field(default_factory=lambda: _f32(0))
    capsule_friction: np.ndarray = dataclasses.field(default_factory=lambda: _f32(0))
    plane: np.ndarray = dataclasses.field(default_factory=lambda: _f32((0, 4)))
    convex_plane_offsets: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(1, np.int32))
    convex_margin: np.ndarray = dataclasses.field(default_factory=lambda: _f32(0))
    convex_friction: np.ndarray = dataclasses.field(default_factory=lambda: _f32(0))
    mesh_points: np.ndarray = dataclasses.field(default_factory=lambda: _f32((0, 3)))
    mesh_triangles: np.ndarray = dataclasses.field(default_factory=lambda: _i32((0, 3)))
    triangle_mesh: np.ndarray = dataclasses.field(default_factory=lambda: _i32(0))
    mesh_margin: np.ndarray = dataclasses.field(default_factory=lambda: _f32(0))
    mesh_friction: np.ndarray = dataclasses.field(default_factory=lambda: _f32(0))
    # (stacks, row) when these are row ``row`` of time-stacked arrays (a bake's prefetched
    # colliders: clothtool.scene.colliders), whose ``sphere_worlds(dtype)`` is (T, s, 4)
    # centres and radii and whose other arrays stand for every row; None otherwise. Where
    # the arrays come from, not what they are: no part of comparing colliders (compare=False)
    source: tuple | None = dataclasses.field(default=None, compare=False)

    @classmethod
    def of(cls, fields: dict) -> "ColliderArrays":
        """ColliderArrays of ``fields`` (every field, by name), the object ``cls(**fields)``
        makes without its generated __init__, which sets a frozen dataclass's fields one by
        one through object.__setattr__: ~3 us, paid at every frame of a bake (a scene's
        prefetched colliders, clothtool.scene.colliders)."""
        arrays = object.__new__(cls)
        arrays.__dict__.update(fields)
        return arrays

    @property
    def empty(self) -> bool:
        return (
            not self.sphere_is_collider.any()
            and self.capsule_spheres.shape[0] == 0
            and self.convex_plane_offsets.shape[0] == 1
            and self.mesh_triangles.shape[0] == 0
        )

    @property
    def has_spheres_or_capsules(self) -> bool:
        return bool(self.sphere_is_collider.any() or self.capsule_spheres.shape[0])

    @property
    def has_meshes(self) -> bool:
        return self.mesh_triangles.shape[0] > 0


def friction_or(friction: np.ndarray, cloth_friction: float) -> np.ndarray:
    """Per-primitive friction, with NaN (a collider that gives none) replaced by the cloth's
    material friction: the one rule every integrator applies."""
    friction = np.asarray(friction, np.float64)
    return np.where(np.isnan(friction), cloth_friction, friction)


@dataclasses.dataclass(frozen=True)
class ColliderInfo:
    """A collider written to the cache as an animated transform.

    Attributes:
        name: valid prim / group name.
        kind: "sphere", "capsule", "plane", "convex" or "mesh".
        params: shape parameters in scene units: sphere {"radius"}; capsule {"radius0",
            "radius1", "length"} (axis +X from -length/2 to +length/2 in the local frame);
            plane {} (normal +Y through the local origin); convex {"planes": (m,4) array};
            mesh {} with the topology below.
        face_vertex_counts, face_vertex_indices, rest_points: mesh colliders only.
    """

    name: str
    kind: str
    params: dict = dataclasses.field(default_factory=dict)
    face_vertex_counts: np.ndarray | None = None
    face_vertex_indices: np.ndarray | None = None
    rest_points: np.ndarray | None = None
