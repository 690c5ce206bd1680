"""Faces against a triangle-mesh collider: a sheet of 5 cm edges falls on a knife-edge ridge
(a closed prism 2 cm wide at its base) whose crest runs between two rows of particles. No
particle ever touches the prism, so with particle collision alone the sheet falls through
it, its faces cutting the crest; with face collision the crest's vertices and edge samples
hold the faces, and the sheet hangs over the ridge with no face deeper than the cloth's
thickness in the prism (grown by its own thickness) in any frame."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from clothtool.collision.colliders import ColliderArrays
from clothtool.settings import SolverConfig
from clothtool.solver.penetration import face_penetration
from tests.physics.test_collision import THICKNESS, box_mesh, cloth_fabric, f32, run, solver_for

RIDGE_THICKNESS = 0.003  # m: the prism's own margin
HALF_WIDTH = 0.01  # m: half the prism's base; particles sit 2.5 cm either side of the crest
HEIGHT = 0.3


def ridge(segments: int = 8, length: float = 1.0) -> ColliderArrays:
    """A closed prism along x: crest (x, 0, 0), base corners (x, -HEIGHT, +-HALF_WIDTH)."""
    section = np.array([[0.0, 0.0], [-HEIGHT, -HALF_WIDTH], [-HEIGHT, HALF_WIDTH]])  # (y, z)
    xs = np.linspace(-length / 2, length / 2, segments + 1)
    points = np.array([[x, y, z] for x in xs for y, z in section])
    triangles = []
    for s in range(segments):
        for k in range(3):
            a, b = 3 * s + k, 3 * s + (k + 1) % 3
            triangles += [[a, b, b + 3], [a, b + 3, a + 3]]
    last = 3 * segments
    triangles += [[0, 2, 1], [last, last + 1, last + 2]]
    one = np.ones(1, np.float32)
    return ColliderArrays(
        mesh_points=f32(points), mesh_triangles=np.array(triangles, np.int32),
        triangle_mesh=np.zeros(len(triangles), np.int32), mesh_margin=RIDGE_THICKNESS * one, mesh_friction=0.5 * one,
    )


def drop(face_collision: bool) -> tuple[list, np.ndarray]:
    """A 0.75 m sheet (16 x 16 particles, 5 cm apart, rows at z = +-2.5 cm) falls from 5 cm
    onto the crest; per frame the face penetration, and the final particle heights."""
    fabric = cloth_fabric(16, 0.75, 0.05)
    colliders = ridge()
    solver = solver_for(fabric, colliders, SolverConfig(face_collision=face_collision))
    depths = []
    for frame in range(24):
        run(solver, 1, first=frame)
        depths.append(face_penetration(solver.world_points(), fabric.triangles, colliders, 1.0, THICKNESS))
    return depths, solver.world_points()[:, 1]


def test_particle_collision_alone_lets_the_sheet_fall_through_the_ridge():
    depths, heights = drop(face_collision=False)
    assert max(d.faces_beyond for d in depths) > 0
    assert heights.max() < -0.1  # through and below the crest


def test_face_collision_hangs_the_sheet_on_the_ridge():
    depths, heights = drop(face_collision=True)
    assert all(d.faces_beyond == 0 for d in depths), [d.faces_beyond for d in depths]
    assert max(d.depth for d in depths) <= THICKNESS
    # held at the crest (the rows beside it within a centimetre above it), hanging down both sides
    assert 0.0 < heights.max() < 0.01
    assert heights.min() < -0.1


# ------------------------------------------------------------------ the measure
def box(margin: float) -> ColliderArrays:
    """The box [-0.1, 0.1]^2 x [-0.2, 0] (top face at y = 0), 2 x 2 cells per side."""
    colliders = box_mesh((-0.1, -0.2, -0.1), (0.1, 0.0, 0.1), 2)
    return dataclasses.replace(colliders, mesh_margin=np.full(1, margin, np.float32))


def triangle(corners) -> tuple[np.ndarray, np.ndarray]:
    return np.asarray(corners, np.float64), np.array([[0, 1, 2]], np.int32)


def test_measure_of_a_face_above_a_mesh_is_margin_minus_its_height():
    """A tilted face whose lowest point, a corner over the box's top, is h above it; and a
    face over the box's edge whose lowest point is on its own edge (edge-edge distance)."""
    for h in (0.001, 0.004):
        points, triangles = triangle([[0.02, h, 0.03], [0.3, h + 0.05, 0.0], [0.0, h + 0.02, 0.3]])
        assert face_penetration(points, triangles, box(0.005), 1.0, THICKNESS).depth == pytest.approx(0.005 - h, abs=1e-6)
    # a face beside the box, its near edge parallel to the box's edge x = 0.1, y = 0, s away
    s = 0.002
    points, triangles = triangle([[0.1 + s, 0.0, -0.05], [0.1 + s, 0.0, 0.05], [0.2, -0.1 + s, 0.0]])
    expected = 0.005 - s
    assert face_penetration(points, triangles, box(0.005), 1.0, THICKNESS).depth == pytest.approx(expected, abs=1e-6)


def test_measure_of_faces_through_a_mesh():
    """A face with a corner 1 cm (3 cm) inside the closed box reaches the margin plus 1 cm
    (3 cm); one through the top with no corner inside at least the margin; a face 5 cm away: none."""
    points, triangles = triangle([[-0.05, 0.01, 0.0], [0.05, 0.01, 0.0], [0.0, -0.01, 0.02]])
    result = face_penetration(points, triangles, box(0.005), 1.0, THICKNESS)
    assert result.depth == pytest.approx(0.015, abs=1e-6) and result.faces_beyond == 1  # its corner 1 cm inside
    points, triangles = triangle([[-0.05, 0.01, 0.0], [0.05, 0.01, 0.0], [0.0, 0.01, 0.3]])
    points[2, 1] = -0.05  # through the top and out the side, its corner beyond the box
    result = face_penetration(points, triangles, box(0.005), 1.0, THICKNESS)
    assert result.depth >= 0.005 - 1e-6 and result.faces_beyond == 1
    points, triangles = triangle([[0.0, -0.03, 0.0], [0.0, 0.05, 0.2], [0.05, 0.05, 0.2]])
    assert face_penetration(points, triangles, box(0.005), 1.0, THICKNESS).depth == pytest.approx(0.035, abs=1e-6)
    points, triangles = triangle([[0.0, 0.05, 0.0], [0.05, 0.05, 0.0], [0.0, 0.05, 0.05]])
    assert face_penetration(points, triangles, box(0.005), 1.0, THICKNESS).depth == -np.inf
