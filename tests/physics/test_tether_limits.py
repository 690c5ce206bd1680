"""Tethers: with tether_scale 1 and tether stiffness 1, no particle of a settled cloth is
farther from its anchor than its tether length.

A tether is a max-distance constraint from a free particle to a pinned one, of length the
geodesic distance over the mesh at rest; the tether stage moves each particle back inside
all of its tethers every iteration. The cloths hang from their top row: one hangs in its rest
pose (gravity pulls straight along the tethers), one starts flat and falls, swings and
settles. Without tethers the same cloths stretch past those lengths by 1 % to 5 % (checked
too, so the limit is the tethers' doing).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from clothtool.settings import SolverConfig, load_material

HANGING = ("XY", (-1.0, -0.01, -1.0, 1.0, 1.0, 1.0))  # hangs in its rest pose, top row pinned
# flat, pinned along z = 0: falls and swings (silk, braked by its air drag to ~0.1 m/s, takes
# 8 s to hang)
FALLING = ("XZ", (-1.0, -1.0, -1.0, 1.0, 1.0, 0.01))


def tether_ratio(solver) -> float:
    """Largest |x_i - x_anchor| / length - 1 over the active tethers (float64)."""
    model = solver.model
    n = model.particle_count
    owner = np.arange(model.tether_anchor.shape[0]) % n
    active = model.tether_anchor != owner
    points = solver.world_points().astype(np.float64)
    lengths = model.tether_rest_length[active].astype(np.float64)
    distance = np.linalg.norm(points[owner[active]] - points[model.tether_anchor[active]], axis=1)
    return float((distance / lengths - 1.0).max())


def settle(fabric, preset, solver_for, tether_stiffness=1.0, seconds=10):
    material = load_material(preset, "test")
    material = dataclasses.replace(material, tether_stiffness=tether_stiffness, tether_scale=1.0)
    solver = solver_for(fabric, material, SolverConfig(frequency=300), gravity=(0.0, -9.81, 0.0))
    fps = 60
    dt = 1.0 / fps
    for frame in range(1, seconds * fps + 1):
        before = solver.world_points().astype(np.float64)
        solver.step(frame, (frame - 1) * dt, dt)
    speed = np.linalg.norm(solver.world_points() - before, axis=1).max() / dt
    return solver, speed


@pytest.mark.parametrize("preset", ["cotton", "jersey", "silk"])
@pytest.mark.parametrize("plane, pin_box", [HANGING, FALLING], ids=["hanging", "falling"])
def test_settled_cloth_stays_within_its_tethers(preset, plane, pin_box, grid_fabric, solver_for):
    fabric = grid_fabric(10, 10, 0.05, plane=plane, pin_box=pin_box, tethers="geodesic")
    assert fabric.tethers_per_particle == 1
    solver, speed = settle(fabric, preset, solver_for)
    assert solver.stage_names[:3] == ["integrate", "wind", "tethers"]
    assert speed < 1e-3, f"the cloth has not settled: it moves at {speed:.3g} m/s after 10 s"
    ratio = tether_ratio(solver)
    assert ratio <= 1e-4, f"a particle ends {ratio:.3%} beyond its tether length"


@pytest.mark.parametrize("preset", ["cotton", "jersey"])
def test_without_tethers_the_same_cloth_overstretches(preset, grid_fabric, solver_for):
    """Control for the test above: the fabric constraints alone let the hanging cloth stretch
    past the tether lengths by more than 1 %."""
    fabric = grid_fabric(10, 10, 0.05, plane=HANGING[0], pin_box=HANGING[1], tethers="geodesic")
    solver, _ = settle(fabric, preset, solver_for, tether_stiffness=0.0, seconds=2)
    assert "tethers" not in solver.stage_names
    assert tether_ratio(solver) > 1e-2


@pytest.mark.parametrize("preset", ["cotton", "jersey"])
def test_two_tether_slots_on_one_island_hold_as_well_as_one(preset, grid_fabric, solver_for):
    """Asking for two anchors per particle on a cloth with one pinned island gives one slot (a
    second, inactive one would halve the tether stiffness, which NvCloth divides by the slot
    count), so the cloth holds as well as with one."""
    fabric = grid_fabric(10, 10, 0.05, plane=HANGING[0], pin_box=HANGING[1], tethers="geodesic", tether_anchors=2)
    assert fabric.tethers_per_particle == 1
    solver, speed = settle(fabric, preset, solver_for)
    assert speed < 1e-3
    ratio = tether_ratio(solver)
    assert ratio <= 1e-4, f"a particle ends {ratio:.3%} beyond its tether length"
