"""Builders for the physics tests of the position-based (NvCloth-style) solver.

Every test in this folder compares the solver with an answer known without the solver's code
(closed forms, or an independent float64 computation with numpy/scipy). The fixtures here
only assemble inputs: a Fabric made directly from arrays (chains, rings, single particles), a
cooked grid, a ClothSolver with a given material, solver settings and environment, and a frame
loop that drives ``solver.step`` the way the bake does (frame f covers [(f-1)/fps, f/fps)).
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import pytest

from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.fabric import Fabric, PhaseType
from clothtool.mesh.shapes import grid
from clothtool.profile import StageProfiler
from clothtool.solver.cloth import ClothSolver
from clothtool.solver.config import Material, SolverConfig
from clothtool.solver.environment import Environment
from clothtool.solver.model import BackstopSettings, MotionSettings, Placement, build_model


def fabric_from_arrays(
    rest_pos,
    inv_mass,
    sets=(),
    phase: PhaseType = PhaseType.VERTICAL,
    triangles=None,
    max_distance=None,
) -> Fabric:
    """A validated Fabric from raw arrays, without tethers.

    sets: sequence of (c_i,2) constraint pairs, one conflict-free set each, all in one phase of
    type ``phase``; rest lengths are the rest pose's distances (float64, then float32).
    particle_area is 1/inv_mass (1 m^2 for pinned particles), so with an areal density of
    1 kg/m^2 a particle's mass is 1/inv_mass kg.
    """
    pos = np.asarray(rest_pos, np.float64)
    n = pos.shape[0]
    w = np.asarray(inv_mass, np.float32)
    area = (1.0 / np.where(w > 0, w, 1.0)).astype(np.float32)
    sets = [np.asarray(s, np.int32).reshape(-1, 2) for s in sets]
    pairs = np.concatenate(sets) if sets else np.zeros((0, 2), np.int32)
    rest_length = np.linalg.norm(pos[pairs[:, 1]] - pos[pairs[:, 0]], axis=1)
    tris = np.zeros((0, 3), np.int32) if triangles is None else np.asarray(triangles, np.int32)
    radius = np.full(n, np.inf) if max_distance is None else np.asarray(max_distance)
    fabric = Fabric(
        rest_pos=pos.astype(np.float32),
        particle_inv_mass=w,
        particle_area=area,
        particle_max_distance=radius.astype(np.float32),
        triangles=tris,
        face_vertex_counts=np.full(tris.shape[0], 3, np.int32),
        face_vertex_indices=tris.reshape(-1),
        face_vertex_uv=np.zeros((0, 2), np.float32),
        phase_type=np.array([int(phase)] if sets else [], np.int32),
        phase_set_offsets=np.array([0, len(sets)] if sets else [0], np.int32),
        set_offsets=np.concatenate([[0], np.cumsum([s.shape[0] for s in sets])]).astype(np.int32),
        constraint_indices=pairs,
        constraint_rest_length=rest_length.astype(np.float32),
        constraint_stiffness=np.ones(pairs.shape[0], np.float32),
        tether_anchor=np.zeros(0, np.int32),
        tether_rest_length=np.zeros(0, np.float32),
        virtual_particles=np.zeros((0, 4), np.int32),
        virtual_particle_weights=np.zeros((0, 3), np.float32),
        virtual_batch_offsets=np.zeros(1, np.int32),
    )
    fabric.validate()
    return fabric


def cooked_grid(columns: int, rows: int, spacing: float, plane: str = "XY", **options) -> Fabric:
    """A cooked grid of quads (stretch, shear and bending phases; tethers when pinned)."""
    mesh = grid(columns, rows, spacing, quads=True, plane=plane)
    return cook_fabric(mesh, CookOptions(**options)).fabric


def make_solver(
    fabric: Fabric,
    material: Material = Material(areal_density=1.0, damping=0.0),
    config: SolverConfig = SolverConfig(),
    gravity=(0.0, -9.81, 0.0),
    wind: Callable[[float], np.ndarray] | None = None,
    motion: MotionSettings = MotionSettings(),
    backstop: BackstopSettings | None = None,
    placement: Placement = Placement(),
    **solver_kwargs,
) -> ClothSolver:
    """A ClothSolver for ``fabric`` in a metre, Y-up scene (placed as is by default);
    ``solver_kwargs`` go to ClothSolver (track, teleport_frames, initial_velocity)."""
    model = build_model("cloth", fabric, material, placement, 1.0, "Y", motion, backstop)
    environment = Environment(gravity=np.asarray(gravity, np.float64), wind=wind)
    return ClothSolver(model, config, environment, StageProfiler(), **solver_kwargs)


def run_frames(
    solver: ClothSolver, fps: float, frames: int, first: int = 1, each: Callable | None = None
) -> float:
    """Simulate ``frames`` frames from frame ``first``, calling ``each(frame)`` after each;
    returns the simulated time at the end (seconds since frame 1 started)."""
    dt = 1.0 / fps
    for frame in range(first, first + frames):
        solver.step(frame, (frame - 1) * dt, dt)
        if each is not None:
            each(frame)
    return (first + frames - 1) * dt


@pytest.fixture
def build_fabric():
    return fabric_from_arrays


@pytest.fixture
def grid_fabric():
    return cooked_grid


@pytest.fixture
def solver_for():
    return make_solver


@pytest.fixture
def simulate():
    return run_frames
