"""The scene's colliders over one frame, as the explicit collide stage's kernels read them.

The colliders are sampled at the frame's start and end (world space) and interpolated
linearly across its substeps, like the position-based solver's start/target scheme; their
surface velocities are the (constant) rates of that interpolation. Margins add the cloth's
thickness to each collider's; a collider's friction is its own, or the cloth's material
friction when the scene gives it none (``clothtool.solver.colliders.friction_or``).
Buffers are allocated once per frame; a substep only fills them.
"""

from __future__ import annotations

import numpy as np

from clothtool.solver.colliders import friction_or

from clothtool.errors import SceneError


def collider_sampler(environment):
    """time -> ColliderArrays from the environment, or None when the scene has no colliders."""
    colliders = getattr(environment, "colliders", None)
    if colliders is None:
        return None
    return getattr(colliders, "at", colliders if callable(colliders) else None)


class _Lerp:
    """start + alpha * (end - start) into a reused buffer, and the rate (end - start) / T."""

    def __init__(self, start, end, frame_dt: float, dtype):
        self.start = np.ascontiguousarray(start, dtype)
        self.delta = np.ascontiguousarray(end, dtype) - self.start
        self.rate = (self.delta / dtype.type(frame_dt)).astype(dtype)
        self.value = self.start.copy()

    def at(self, alpha) -> np.ndarray:
        np.multiply(self.delta, alpha, out=self.value)
        self.value += self.start
        return self.value


class ColliderMotion:
    """One frame of colliders for one cloth (see module docstring)."""

    def __init__(self, sampler, name: str, thickness: float, friction: float, dtype):
        self.sampler = sampler
        self.name = name
        self.thickness = thickness  # cloth thickness in scene units
        self.friction = friction
        self.dtype = np.dtype(dtype)
        self.active = False

    def _combine(self, friction: np.ndarray) -> np.ndarray:
        return friction_or(friction, self.friction).astype(self.dtype)

    def _margin(self, margin: np.ndarray) -> np.ndarray:
        return (np.asarray(margin, np.float64) + self.thickness).astype(self.dtype)

    def begin_frame(self, time: float, frame_dt: float) -> None:
        a, b = self.sampler(time), self.sampler(time + frame_dt)
        for field in ("sphere_center", "plane", "mesh_points", "capsule_spheres", "mesh_triangles", "convex_plane_offsets"):
            if np.shape(getattr(a, field)) != np.shape(getattr(b, field)):
                raise SceneError(
                    f"cloth '{self.name}': the colliders' {field} change shape between t = {time:g} s and "
                    f"t = {time + frame_dt:g} s; colliders must keep their topology during a frame"
                )
        dtype = self.dtype
        i32 = lambda x: np.ascontiguousarray(x, np.int32)  # noqa: E731
        self.center = _Lerp(a.sphere_center, b.sphere_center, frame_dt, dtype)
        self.radius = _Lerp(a.sphere_radius, b.sphere_radius, frame_dt, dtype)
        self.spheres = i32(np.flatnonzero(a.sphere_is_collider))
        self.sphere_margin = self._margin(a.sphere_margin[self.spheres])
        self.sphere_friction = self._combine(a.sphere_friction[self.spheres])
        self.capsules = i32(a.capsule_spheres)
        self.capsule_margin = self._margin(a.capsule_margin)
        self.capsule_friction = self._combine(a.capsule_friction)
        self.plane = _Lerp(a.plane, b.plane, frame_dt, dtype)
        self.plane_offsets = i32(a.convex_plane_offsets)
        self.convex_margin = self._margin(a.convex_margin)
        self.convex_friction = self._combine(a.convex_friction)
        self.points = _Lerp(a.mesh_points, b.mesh_points, frame_dt, dtype)
        self.triangles = i32(a.mesh_triangles)
        meshes = a.mesh_margin.shape[0]
        counts = np.bincount(a.triangle_mesh, minlength=meshes) if a.triangle_mesh.size else np.zeros(meshes, np.int64)
        self.mesh_offsets = i32(np.concatenate([[0], np.cumsum(counts)]))
        if a.triangle_mesh.size and np.any(np.diff(a.triangle_mesh) < 0):
            raise SceneError(f"cloth '{self.name}': mesh collider triangles must be grouped by mesh")
        self.mesh_margin = self._margin(a.mesh_margin)
        self.mesh_friction = self._combine(a.mesh_friction)
        self.active = bool(self.spheres.size or self.capsules.size or self.plane_offsets.size > 1 or self.triangles.size)

    def at(self, alpha: float) -> None:
        """Interpolate the geometry to the fraction ``alpha`` of the frame."""
        alpha = self.dtype.type(alpha)
        self.center.at(alpha)
        self.radius.at(alpha)
        self.plane.at(alpha)
        self.points.at(alpha)
