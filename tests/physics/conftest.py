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
from clothtool.settings import BackstopSettings, Material, MotionSettings, Placement, SolverConfig
from clothtool.solver.cloth import ClothSolver
from clothtool.solver.environment import Environment
from clothtool.solver.model import build_model


def fabric_from_arrays(
    rest_pos,
    inv_mass,
    sets=(),
    phase: PhaseType = PhaseType.VERTICAL,
    triangles=None,
    max_distance=None,
    area=None,
) -> Fabric:
    """A validated Fabric from raw arrays, without tethers.

    sets: sequence of (c_i,2) constraint pairs, one conflict-free set each, all in one phase of
    type ``phase``; rest lengths are the rest pose's distances (float64, then float32).
    particle_area is ``area`` (m^2, a scalar or per particle) or else 1/inv_mass (1 m^2 for
    pinned particles), so with an areal density of 1 kg/m^2 a particle's mass is 1/inv_mass kg.
    """
    pos = np.asarray(rest_pos, np.float64)
    n = pos.shape[0]
    w = np.asarray(inv_mass, np.float32)
    if area is None:
        area = (1.0 / np.where(w > 0, w, 1.0)).astype(np.float32)
    else:
        area = np.broadcast_to(np.asarray(area, np.float32), (n,)).copy()
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


# ---------------------------------------------------------------- analytic scenes and hard cases
# Helpers shared by test_analytic_*.py and test_hard_*.py (and benchmarks/accuracy/, which runs
# the same scenes over more settings). Measurements are float64 numpy, independent of the
# solver's kernels.

import dataclasses  # noqa: E402  (appended section)


def crossing_times(times, values) -> np.ndarray:
    """Times at which the sampled signal ``values`` changes sign, each interpolated linearly
    between the two samples around it."""
    t = np.asarray(times, np.float64)
    x = np.asarray(values, np.float64)
    i = np.flatnonzero(np.sign(x[:-1]) * np.sign(x[1:]) < 0)
    return t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])


def stretch_strain(solver) -> float:
    """Largest stretch strain |x_b - x_a| / rest - 1 over the stretch (vertical and
    horizontal) constraints of ``solver``'s cloth, in float64 (0 when it has none)."""
    model = solver.model
    index = np.concatenate([model.phase_constraints("vertical"), model.phase_constraints("horizontal")])
    if index.size == 0:
        return 0.0
    pairs = model.constraint_indices[index]
    rest = model.constraint_rest_length[index].astype(np.float64)
    points = solver.state.cur[:, :3].astype(np.float64)
    length = np.linalg.norm(points[pairs[:, 1]] - points[pairs[:, 0]], axis=1)
    return float((length / rest - 1.0).max())


def particle_speed(solver, h: float) -> float:
    """Largest particle speed over the last iteration of length ``h``, world frame, m/s
    (inf when a position is not finite)."""
    velocity = solver.world_velocities(h).astype(np.float64)
    if not np.isfinite(velocity).all():
        return float("inf")
    return float(np.linalg.norm(velocity, axis=1).max())


def make_collider_solver(fabric, colliders, material: Material, config: SolverConfig, gravity=(0.0, -9.81, 0.0), **kwargs):
    """A ClothSolver like ``make_solver``'s whose environment has ``colliders`` (a
    ColliderArrays, or a function of time in seconds returning one)."""
    call = colliders if callable(colliders) else (lambda t: colliders)
    model = build_model("cloth", fabric, material, Placement(), 1.0, "Y")
    environment = Environment(gravity=np.asarray(gravity, np.float64), colliders=call)
    return ClothSolver(model, config, environment, StageProfiler(), **kwargs)


@dataclasses.dataclass
class HardCaseRun:
    """What one run of a hard case measured, in SI units (see tests/physics/test_hard_*.py).

    nan_frame: first frame that ended with a NaN or infinite particle (None: never);
    max_speed: largest particle speed at the end of any frame (m/s);
    late_strain: largest stretch strain at the ends of the frames from ``settle`` seconds on;
    final_strain: stretch strain at the end of the run;
    penetration: deepest a particle ended an iteration inside a collider's margin (m);
    energy_excess: largest (energy - energy released) over the run (J; <= 0 passes);
    notes: anything else worth a column in the report (keys starting with "_" hold raw
        values for the tests and are left out of the summary).
    """

    frames: int = 0
    nan_frame: int | None = None
    max_speed: float = 0.0
    late_strain: float = 0.0
    final_strain: float = 0.0
    penetration: float = 0.0
    energy_excess: float = float("-inf")
    notes: dict = dataclasses.field(default_factory=dict)

    def failures(
        self,
        speed_limit: float,
        strain_target: float = float("inf"),
        penetration_limit: float = float("inf"),
        energy_tolerance: float | None = None,
    ) -> list[str]:
        """One line per criterion the run misses (an empty list: it passes)."""
        failed = []
        if self.nan_frame is not None:
            failed.append(f"NaN/Inf at frame {self.nan_frame}")
        if not self.max_speed <= speed_limit:
            failed.append(f"max speed {self.max_speed:.3g} m/s > {speed_limit:g}")
        if not self.late_strain <= strain_target:
            failed.append(f"strain {self.late_strain:.2%} after settling > {strain_target:.1%}")
        if not self.penetration <= penetration_limit:
            failed.append(f"penetration {1000 * self.penetration:.2f} mm > {1000 * penetration_limit:.2f} mm")
        if energy_tolerance is not None and not self.energy_excess <= energy_tolerance:
            failed.append(f"energy rose {self.energy_excess:.3g} J above the released energy")
        return failed

    def summary(self) -> str:
        parts = [f"vmax {self.max_speed:.3g} m/s"]
        if self.late_strain or self.final_strain:
            parts.append(f"strain {self.late_strain:.2%} late / {self.final_strain:.2%} final")
        if self.penetration > 0:
            parts.append(f"penetration {1000 * self.penetration:.2f} mm")
        if np.isfinite(self.energy_excess):
            parts.append(f"energy excess {self.energy_excess:+.3g} J")
        parts += [f"{key} {value}" for key, value in self.notes.items() if not key.startswith("_")]
        return ", ".join(parts)


@pytest.fixture
def collider_solver_for():
    return make_collider_solver
