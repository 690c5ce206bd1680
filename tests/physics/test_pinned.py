"""Pinned particles (inverse mass 0) never move: bit for bit, every frame of a long bake.

Each stage must either skip a particle with w = 0 or move it by (something) * w = 0, so a
pinned particle's float32 position stays exactly its rest position however the rest of the
cloth swings, stretches and drags in still air. The cloth starts flat and pinned along one
edge, so it falls and swings; each test also checks that it did move, or the pins would be
tested on a cloth at rest.
"""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.settings import BackstopSettings, Placement, SolverConfig, load_material

PRESETS = ["cotton", "denim", "jersey", "leather", "silk"]
GRAVITY = (0.0, -9.81, 0.0)


@pytest.fixture(scope="module")
def edge_pinned_fabric():
    from clothtool.cook.cooker import CookOptions, cook_fabric
    from clothtool.mesh.shapes import grid

    mesh = grid(8, 8, 0.05, quads=True, plane="XZ")
    # pin the row at z = 0 (geodesic tethers to it come with the pins)
    return cook_fabric(mesh, CookOptions(pin_box=(-1.0, -1.0, -1.0, 1.0, 1.0, 0.01))).fabric


def rotation(axis, angle: float) -> np.ndarray:
    axis = np.asarray(axis, np.float64) / np.linalg.norm(axis)
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * k @ k


def bake_and_watch_pins(solver, pinned, frames: int):
    """Run ``frames`` frames at 60 fps; return (frames in which a pinned particle was not
    bit-identical to its rest position, largest distance any particle reached from rest)."""
    rest = solver.model.rest_pos.copy()
    moved_frames = []
    travel = [0.0]

    def check(frame):
        points = solver.world_points()
        if not np.array_equal(points[pinned], rest[pinned]):
            moved_frames.append(frame)
        travel[0] = max(travel[0], float(np.linalg.norm(points - rest, axis=1).max()))

    dt = 1.0 / 60.0
    for frame in range(1, frames + 1):
        solver.step(frame, (frame - 1) * dt, dt)
        check(frame)
    return moved_frames, travel[0]


@pytest.mark.parametrize("preset", PRESETS)
@pytest.mark.parametrize("motion", [False, True], ids=["free", "motion-spheres"])
def test_pinned_particles_stay_bit_exact(preset, motion, edge_pinned_fabric, solver_for):
    fabric = edge_pinned_fabric
    if motion:  # every particle, pinned ones included, gets a 2 cm motion sphere
        fabric = fabric.replace(particle_max_distance=np.full(fabric.particle_count, 0.02, np.float32))
    solver = solver_for(fabric, load_material(preset, "test"), SolverConfig(frequency=300), gravity=GRAVITY)
    pinned = fabric.pinned
    assert 0 < pinned.sum() < fabric.particle_count
    moved_frames, travel = bake_and_watch_pins(solver, pinned, 300)  # 5 s
    assert not moved_frames, f"pinned particles moved in frames {moved_frames[:5]} (of {len(moved_frames)})"
    assert np.isfinite(solver.world_points()).all()
    assert travel > 0.015, f"the free particles moved only {travel:.3g} m: the pins carried no load"


@pytest.mark.parametrize("preset", ["cotton", "jersey"])
def test_pinned_particles_stay_bit_exact_with_backstop(preset, edge_pinned_fabric, solver_for):
    """distance = 0 puts every rest position on its sphere's surface; under a generic placement
    float32 rounding puts some pinned particles a hair inside their spheres."""
    placement = Placement(rotation=rotation((1.0, 2.0, 3.0), 0.7))
    solver = solver_for(
        edge_pinned_fabric, load_material(preset, "test"), SolverConfig(frequency=300), gravity=GRAVITY,
        backstop=BackstopSettings(radius=0.3, distance=0.0), placement=placement,
    )
    moved_frames, travel = bake_and_watch_pins(solver, edge_pinned_fabric.pinned, 120)
    assert travel > 0.005, f"the free particles moved only {travel:.3g} m: the pins carried no load"
    assert not moved_frames, f"pinned particles moved in frames {moved_frames[:5]} (of {len(moved_frames)})"
