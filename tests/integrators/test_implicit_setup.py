"""Builders shared by the implicit integrator's tests (no tests in this module).

Fabrics are made straight from arrays (no cooking: the implicit integrator needs only the
triangles, UVs, masses and pins), solvers are placed as is in a metre, Y-up scene.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from clothtool.fabric import Fabric
from clothtool.integrators.implicit.solver import ImplicitClothSolver
from clothtool.mesh.shapes import grid
from clothtool.mesh.topology import vertex_areas
from clothtool.profile import StageProfiler
from clothtool.settings import Material, MotionSettings, Placement, SolverConfig
from clothtool.solver.environment import Environment
from clothtool.solver.model import build_model


def fabric_from_mesh(pos, counts, indices, uv=None, pinned=(), max_distance=None) -> Fabric:
    """A validated Fabric of a triangle mesh with lumped vertex areas (so masses are
    areal density x area) and the given particles pinned."""
    pos = np.asarray(pos, np.float64)
    n = pos.shape[0]
    counts = np.asarray(counts, np.int32)
    indices = np.asarray(indices, np.int32)
    area = vertex_areas(pos, counts, indices)
    inv_mass = 1.0 / area
    inv_mass[list(pinned)] = 0.0
    triangles = indices.reshape(-1, 3)
    fabric = Fabric(
        rest_pos=pos.astype(np.float32),
        particle_inv_mass=inv_mass.astype(np.float32),
        particle_area=area.astype(np.float32),
        particle_max_distance=(
            np.full(n, np.inf, np.float32) if max_distance is None else np.asarray(max_distance, np.float32)
        ),
        triangles=triangles.astype(np.int32),
        face_vertex_counts=counts,
        face_vertex_indices=indices,
        face_vertex_uv=np.zeros((0, 2), np.float32) if uv is None else np.asarray(uv, np.float32),
        phase_type=np.zeros(0, np.int32),
        phase_set_offsets=np.zeros(1, np.int32),
        set_offsets=np.zeros(1, np.int32),
        constraint_indices=np.zeros((0, 2), np.int32),
        constraint_rest_length=np.zeros(0, np.float32),
        constraint_stiffness=np.zeros(0, np.float32),
        tether_anchor=np.zeros(0, np.int32),
        tether_rest_length=np.zeros(0, np.float32),
        virtual_particles=np.zeros((0, 4), np.int32),
        virtual_particle_weights=np.zeros((0, 3), np.float32),
        virtual_batch_offsets=np.zeros(1, np.int32),
    )
    fabric.validate()
    return fabric


def grid_fabric(columns: int, rows: int | None = None, size: float = 1.0, plane: str = "XY", pinned=(),
                origin=(0.0, 0.0, 0.0), uv: bool = True, max_distance=None) -> Fabric:
    """A ``size``-metre-wide triangulated grid (``clothtool.mesh.shapes.grid``)."""
    rows = columns if rows is None else rows
    mesh = grid(columns, rows, size / (columns - 1), plane=plane, origin=origin)
    return fabric_from_mesh(mesh.vertex_pos, mesh.face_vertex_counts, mesh.face_vertex_indices,
                            mesh.face_vertex_uv if uv else None, pinned, max_distance)


def make_solver(fabric: Fabric, material: Material, frequency: float = 24.0, gravity=(0.0, -9.81, 0.0),
                colliders=None, motion: MotionSettings = MotionSettings(), precision: str = "float32",
                **config_overrides) -> ImplicitClothSolver:
    model = build_model("cloth", fabric, material, Placement(), 1.0, "Y", motion)
    config = SolverConfig(frequency=frequency, precision=precision)
    if config_overrides:
        config = _ConfigWith(config, config_overrides)
    environment = Environment(gravity=np.asarray(gravity, np.float64), colliders=colliders)
    return ImplicitClothSolver(model, config, environment, StageProfiler())


class _ConfigWith:
    """A SolverConfig with extra attributes (cg_tolerance, cg_max_iterations) that the
    solver reads with getattr before SolverConfig has them."""

    def __init__(self, config: SolverConfig, extra: dict):
        self._config = config
        self.__dict__.update(extra)

    def __getattr__(self, name):
        return getattr(self._config, name)


def run(solver: ImplicitClothSolver, fps: float, frames: int, each=None) -> None:
    dt = 1.0 / fps
    for frame in range(1, frames + 1):
        solver.step(frame, (frame - 1) * dt, dt)
        if each is not None:
            each(frame)


def replace(material: Material, **changes) -> Material:
    return dataclasses.replace(material, **changes)
