"""ClothModel: the static data of one simulated cloth, in scene units.

Built from a fabric, the instance placement (units, up axis, uniform scale, rotation,
translation) and the material. Positions are in the cloth's *local* frame: the world when the
cloth follows no track, the track's frame when it does.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from clothtool.fabric import Fabric, PhaseType
from clothtool.mesh.units import up_axis_rotation
from clothtool.settings import BackstopSettings, Material, MotionSettings, Placement


@dataclasses.dataclass(frozen=True, eq=False)
class ClothModel:
    """Static arrays of one cloth (see module docstring). f32 unless noted."""

    name: str
    fabric: Fabric
    material: Material
    rest_pos: np.ndarray  # (n,3) local frame, scene units
    inv_mass: np.ndarray  # (n,) 1/kg, 0 = pinned
    mass: np.ndarray  # f64 (n,) kg
    triangles: np.ndarray  # i32 (t,3)
    constraint_indices: np.ndarray  # i32 (c,2)
    constraint_rest_length: np.ndarray  # (c,) scene units
    constraint_stiffness: np.ndarray  # (c,)
    set_offsets: np.ndarray  # i32 (s+1,)
    phase_set_offsets: np.ndarray  # i32 (p+1,)
    phase_labels: tuple[str, ...]  # per phase: vertical / horizontal / shearing / bending
    tether_anchor: np.ndarray  # i32 (k*n,)
    tether_rest_length: np.ndarray  # (k*n,) scene units
    max_distance: np.ndarray  # (n,) scene units, inf = free
    motion: MotionSettings
    backstop_centers: np.ndarray | None  # (n,3) local frame
    backstop_radii: np.ndarray | None  # (n,)
    units_to_meters: float  # metres per scene unit
    length_scale: float  # scene units per fabric unit

    @property
    def particle_count(self) -> int:
        return int(self.rest_pos.shape[0])

    @property
    def has_motion_constraints(self) -> bool:
        return bool(np.isfinite(self.max_distance).any())

    @property
    def has_tethers(self) -> bool:
        n = self.particle_count
        return bool(np.any(self.tether_anchor != np.arange(self.tether_anchor.shape[0]) % n))

    def phase_constraints(self, label: str) -> np.ndarray:
        """Indices of the constraints belonging to phases of type ``label``."""
        spans = []
        for p, phase_label in enumerate(self.phase_labels):
            if phase_label == label:
                first = self.set_offsets[self.phase_set_offsets[p]]
                last = self.set_offsets[self.phase_set_offsets[p + 1]]
                spans.append(np.arange(first, last))
        return np.concatenate(spans) if spans else np.zeros(0, np.int64)


def vertex_normals(pos: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """f64 (n,3) area-weighted unit vertex normals."""
    p = pos.astype(np.float64)
    face_normals = np.cross(p[triangles[:, 1]] - p[triangles[:, 0]], p[triangles[:, 2]] - p[triangles[:, 0]])
    normals = np.zeros_like(p)
    for corner in range(3):
        np.add.at(normals, triangles[:, corner], face_normals)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return normals / np.maximum(length, 1e-30)


def build_model(
    name: str,
    fabric: Fabric,
    material: Material,
    placement: Placement,
    scene_meters_per_unit: float,
    scene_up_axis: str,
    motion: MotionSettings = MotionSettings(),
    backstop: BackstopSettings | None = None,
) -> ClothModel:
    """Place ``fabric`` in the scene and attach ``material``."""
    length_scale = fabric.meters_per_unit / scene_meters_per_unit * placement.scale
    rotation = placement.rotation @ up_axis_rotation(fabric.up_axis, scene_up_axis)
    rest = (fabric.rest_pos.astype(np.float64) * length_scale) @ rotation.T + placement.translation
    inv_mass = (fabric.particle_inv_mass.astype(np.float64) / material.areal_density).astype(np.float32)
    mass = fabric.particle_area.astype(np.float64) * material.areal_density
    labels = tuple(PhaseType(int(t)).label for t in fabric.phase_type)
    centers = radii = None
    if backstop is not None:
        normals = vertex_normals(rest, fabric.triangles)
        centers = (rest - normals * (backstop.distance + backstop.radius)).astype(np.float32)
        radii = np.full(fabric.particle_count, backstop.radius, np.float32)
    return ClothModel(
        name=name,
        fabric=fabric,
        material=material,
        rest_pos=rest.astype(np.float32),
        inv_mass=inv_mass,
        mass=mass,
        triangles=fabric.triangles,
        constraint_indices=fabric.constraint_indices,
        constraint_rest_length=(fabric.constraint_rest_length * np.float32(length_scale)).astype(np.float32),
        constraint_stiffness=fabric.constraint_stiffness,
        set_offsets=fabric.set_offsets,
        phase_set_offsets=fabric.phase_set_offsets,
        phase_labels=labels,
        tether_anchor=fabric.tether_anchor,
        tether_rest_length=(fabric.tether_rest_length * np.float32(length_scale)).astype(np.float32),
        max_distance=(fabric.particle_max_distance * np.float32(length_scale)).astype(np.float32),
        motion=motion,
        backstop_centers=centers,
        backstop_radii=radii,
        units_to_meters=scene_meters_per_unit,
        length_scale=length_scale,
    )
