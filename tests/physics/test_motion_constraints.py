"""Motion constraints (max distance): a particle with radius r > 0 never ends a frame farther
than r from its rest position; r <= 0 pins it there.

The cloth is a triangle mesh with no fabric constraints, so that the motion stage is the last
one to move a particle in each iteration, under strong gravity (4 g) and a gusting wind
(drag and lift on every triangle). Radii are random between 0 and 8 cm; three particles have
radius 0, and in a second run every radius is scaled by 0.5 and lowered by a bias of 2 cm, so
that some become negative (a radius below 0 counts as 0).
"""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.settings import Material, MotionSettings, SolverConfig


def gust(t: float) -> np.ndarray:
    return np.array([15.0 * np.sin(3.0 * t), 5.0, 10.0 * np.cos(2.0 * t)])


@pytest.fixture(scope="module")
def sheet():
    """5 x 5 particles, 5 cm apart, flat in XZ; triangles but no constraints; 0.1 kg each."""
    from clothtool.cook.cooker import CookOptions, cook_fabric
    from clothtool.mesh.shapes import grid

    mesh = grid(5, 5, 0.05, plane="XZ")
    triangles = cook_fabric(mesh, CookOptions(tethers="none")).fabric.triangles
    radius = np.random.default_rng(0).uniform(0.0, 0.08, mesh.vertex_count)
    radius[[0, 6, 12]] = 0.0
    return mesh.vertex_pos, triangles, radius


@pytest.mark.parametrize("frequency", [120, 300])
@pytest.mark.parametrize(
    "motion", [MotionSettings(), MotionSettings(scale=0.5, bias=-0.02)], ids=["plain", "scaled"]
)
def test_particles_stay_within_their_motion_spheres(frequency, motion, sheet, build_fabric, solver_for, simulate):
    pos, triangles, radius = sheet
    fabric = build_fabric(pos, np.full(len(pos), 10.0), triangles=triangles, max_distance=radius)
    material = Material(areal_density=1.0, damping=0.0, drag_coefficient=0.3, lift_coefficient=0.2)
    config = SolverConfig(frequency=frequency)
    solver = solver_for(fabric, material, config, gravity=(0.0, -40.0, 0.0), wind=gust, motion=motion)
    assert solver.stage_names == ["integrate", "wind", "motion"]
    rest = solver.model.rest_pos.astype(np.float64)
    limit = np.maximum(radius * motion.scale + motion.bias, 0.0)
    pinned = limit <= 0.0
    assert 3 <= pinned.sum() < len(pos) - 5
    worst = [0.0]
    reach = np.zeros(len(pos))

    def check(frame):
        distance = np.linalg.norm(solver.world_points().astype(np.float64) - rest, axis=1)
        assert np.isfinite(distance).all(), f"non-finite positions in frame {frame}"
        worst[0] = max(worst[0], float((distance - limit * (1.0 + 1e-6)).max()))
        np.maximum(reach, distance, out=reach)

    simulate(solver, 60, 120, each=check)  # 2 s
    assert worst[0] <= 1e-7, f"a particle ended a frame {worst[0]:.3g} m outside its motion sphere"
    assert reach[pinned].max() <= 1e-7, (
        f"a particle with radius <= 0 left its rest position by {reach[pinned].max():.3g} m"
    )
    # the spheres were doing the work: the free particles reached their surfaces
    assert np.all(reach[~pinned] > 0.99 * limit[~pinned])
