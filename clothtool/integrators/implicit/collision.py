"""Cloth-collider contact for the implicit integrator (Bridson, Fedkiw & Anderson 2002, as the
slides 23-30 describe), against the scene's colliders in world space.

Distances. ``phi(p)`` is the signed distance from p to the nearest collider surface minus
that collider's margin (negative inside), with the outward unit normal there, the collider's
friction and the velocity of its surface point. Primitives: spheres; tapered capsules (the
convex hull of two spheres: exact distance to the cone-sphere); convexes (the largest
plane distance, exact on faces, a lower bound near edges); triangle meshes (closest point
over the triangles found in a uniform grid, signed by the face normal (at a shared edge or
corner, by the face best aligned with the offset), plus a segment test
that catches a particle crossing a face from the front within one step). A particle that is
deeper inside a mesh than the grid's search radius (cloth thickness plus mesh margin) is not
seen. Colliders move linearly over a step: their velocity is (end - start) / h (sphere
centres and radii, capsule ends, plane offsets, mesh points; a convex has no tangential
velocity).

Per step, for every free particle, with x0 the start position, v the candidate average
velocity (x1 - x0)/h from the solve, thickness th = cloth thickness, h the step:

1. repulsion, at the start positions (start-of-step geometry): if the particle lies within
   the thickness, d = th - phi(x0) > 0 and the relative normal velocity is
   v_r < 0.1 d / h, it gets the normal impulse I = min(h k d, m (0.1 d/h - v_r)) (the
   slide's cap; k = the cloth's stretch modulus);
2. friction with every normal impulse I: the relative tangential velocity v_T becomes
   max(1 - mu I / (m |v_T|), 0) v_T (Coulomb, static and kinetic with one mu);
3. inelastic impulses, at the end positions (end-of-step geometry): a particle whose end
   position x0 + h v lies within the thickness (or whose path crosses a mesh face) gets the
   normal velocity change that lands it on the surface (+ thickness) instead of passing
   through, i.e. it stops on the collider rather than bouncing; friction as in 2. Repeated
   ``passes`` times, so a second collider is resolved too;
4. a final robust pass: any particle still within the thickness is moved onto the surface
   along the normal with no friction.

The average velocity after 1-4 sets the new position x1 = x0 + h v; the velocity the
particle keeps gets the same impulses and then loses its inward relative normal component
along the last contact normal (a completely inelastic contact: the particle leaves the step
resting on the collider, not driving into it). The solver runs strain limiting between
steps 3 and 4 (then motion constraints), so that step 4 has the last word on positions.

This module packs the colliders (numpy); the kernels are in ``kernels.implicit_collision``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from clothtool.solver.colliders import friction_or

GRID_MAX_CELLS_PER_AXIS = 64


class ColliderSet(NamedTuple):
    """One instant of the colliders, float64/int32, world space, scene units (see
    ``pack_colliders``); velocities are per second over the step."""

    sphere: np.ndarray  # (s,4) centre xyz, radius
    sphere_velocity: np.ndarray  # (s,4) d/dt of the above
    sphere_margin: np.ndarray  # (s,)
    sphere_friction: np.ndarray  # (s,)
    sphere_active: np.ndarray  # u8 (s,): a collider on its own (not only a capsule end)
    capsule: np.ndarray  # i32 (c,2) sphere indices
    capsule_margin: np.ndarray  # (c,)
    capsule_friction: np.ndarray  # (c,)
    plane: np.ndarray  # (p,4) n, d: solid where n.x < d
    plane_rate: np.ndarray  # (p,) dd/dt
    convex_offsets: np.ndarray  # i32 (k+1,)
    convex_margin: np.ndarray  # (k,)
    convex_friction: np.ndarray  # (k,)
    mesh_points: np.ndarray  # (m,3)
    mesh_velocity: np.ndarray  # (m,3)
    mesh_triangles: np.ndarray  # i32 (t,3)
    triangle_margin: np.ndarray  # (t,)
    triangle_friction: np.ndarray  # (t,)
    grid_geometry: np.ndarray  # (4,) origin xyz, cell size
    grid_shape: np.ndarray  # i32 (3,)
    cell_start: np.ndarray  # i32 (cells+1,) CSR into cell_items
    cell_items: np.ndarray  # i32 triangle indices


# ----------------------------------------------------------------- packing (numpy)
def _f64(a, shape=None) -> np.ndarray:
    out = np.ascontiguousarray(a, np.float64)
    return out.reshape(shape) if shape is not None else out


def _rate(start: np.ndarray, end: np.ndarray, h: float) -> np.ndarray:
    if start.shape != end.shape:
        return np.zeros(end.shape, np.float64)
    return (end.astype(np.float64) - start.astype(np.float64)) / h


def pack_colliders(start, end, h: float, radius: float, cloth_friction: float = 0.5) -> tuple[ColliderSet, ColliderSet]:
    """The colliders at the start and the end of a step of length ``h`` (two
    ``clothtool.solver.colliders.ColliderArrays`` of the same scene), with their velocities;
    mesh triangles are gridded for queries up to ``radius`` from their surface. Colliders that
    give no friction (NaN) get ``cloth_friction``."""
    sets = []
    for arrays in (start, end):
        sphere = np.concatenate([_f64(arrays.sphere_center, (-1, 3)), _f64(arrays.sphere_radius)[:, None]], axis=1)
        sphere_start = np.concatenate([_f64(start.sphere_center, (-1, 3)), _f64(start.sphere_radius)[:, None]], axis=1)
        sphere_end = np.concatenate([_f64(end.sphere_center, (-1, 3)), _f64(end.sphere_radius)[:, None]], axis=1)
        mesh_triangles = np.ascontiguousarray(arrays.mesh_triangles, np.int32).reshape(-1, 3)
        mesh_of = np.asarray(arrays.triangle_mesh, np.int64)
        points = _f64(arrays.mesh_points, (-1, 3))
        triangle_margin = _f64(arrays.mesh_margin)[mesh_of] if mesh_of.size else np.zeros(0)
        geometry, shape, cell_start, items = build_triangle_grid(points, mesh_triangles, triangle_margin + radius)
        sets.append(
            ColliderSet(
                sphere=sphere,
                sphere_velocity=_rate(sphere_start, sphere_end, h),
                sphere_margin=_f64(arrays.sphere_margin),
                sphere_friction=friction_or(arrays.sphere_friction, cloth_friction),
                sphere_active=np.ascontiguousarray(arrays.sphere_is_collider, np.uint8),
                capsule=np.ascontiguousarray(arrays.capsule_spheres, np.int32).reshape(-1, 2),
                capsule_margin=_f64(arrays.capsule_margin),
                capsule_friction=friction_or(arrays.capsule_friction, cloth_friction),
                plane=_f64(arrays.plane, (-1, 4)),
                plane_rate=_rate(_f64(start.plane, (-1, 4))[:, 3], _f64(end.plane, (-1, 4))[:, 3], h),
                convex_offsets=np.ascontiguousarray(arrays.convex_plane_offsets, np.int32),
                convex_margin=_f64(arrays.convex_margin),
                convex_friction=friction_or(arrays.convex_friction, cloth_friction),
                mesh_points=points,
                mesh_velocity=_rate(_f64(start.mesh_points, (-1, 3)), _f64(end.mesh_points, (-1, 3)), h),
                mesh_triangles=mesh_triangles,
                triangle_margin=triangle_margin,
                triangle_friction=friction_or(arrays.mesh_friction, cloth_friction)[mesh_of] if mesh_of.size else np.zeros(0),
                grid_geometry=geometry,
                grid_shape=shape,
                cell_start=cell_start,
                cell_items=items,
            )
        )
    return sets[0], sets[1]


def build_triangle_grid(points: np.ndarray, triangles: np.ndarray, inflate: np.ndarray):
    """A uniform grid over the triangles' bounding boxes, each grown by its ``inflate``
    (t,): (geometry (4,) origin + cell size, shape i32 (3,), cell_start i32 (cells+1,),
    cell_items i32: CSR of the triangles overlapping each cell, cell = (i * ny + j) * nz + k)."""
    if triangles.shape[0] == 0:
        return np.array([0.0, 0.0, 0.0, 1.0]), np.ones(3, np.int32), np.zeros(2, np.int32), np.zeros(0, np.int32)
    corners = points[triangles]
    low = corners.min(axis=1) - inflate[:, None]
    high = corners.max(axis=1) + inflate[:, None]
    origin = low.min(axis=0)
    extent = high.max(axis=0) - origin
    cell = max(float(np.mean(np.max(high - low, axis=1))), float(extent.max()) / GRID_MAX_CELLS_PER_AXIS, 1e-12)
    shape = np.maximum(np.ceil(extent / cell).astype(np.int64), 1)
    first = np.clip(np.floor((low - origin) / cell).astype(np.int64), 0, shape - 1)
    last = np.clip(np.floor((high - origin) / cell).astype(np.int64), 0, shape - 1)
    span = last - first + 1  # (t,3) cells per axis
    count = span.prod(axis=1)
    owner = np.repeat(np.arange(triangles.shape[0]), count)
    local = np.arange(owner.shape[0]) - np.repeat(np.cumsum(count) - count, count)
    ny_nz = span[owner, 1] * span[owner, 2]
    i = first[owner, 0] + local // ny_nz
    j = first[owner, 1] + (local % ny_nz) // span[owner, 2]
    k = first[owner, 2] + local % span[owner, 2]
    cells = (i * shape[1] + j) * shape[2] + k
    order = np.argsort(cells, kind="stable")
    cell_start = np.zeros(int(shape.prod()) + 1, np.int64)
    np.cumsum(np.bincount(cells, minlength=int(shape.prod())), out=cell_start[1:])
    geometry = np.array([*origin, cell], np.float64)
    return geometry, shape.astype(np.int32), cell_start.astype(np.int32), owner[order].astype(np.int32)
