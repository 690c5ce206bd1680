"""Faces against sphere and capsule colliders: the face penetration measure against closed
forms, and face collision (each face too large for a collider collides its deepest point)
keeping a sheet's faces out of a rod thinner than its edges, where particle collision alone
lets them in.
"""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.collision.colliders import ColliderArrays
from clothtool.settings import SolverConfig
from clothtool.solver.facepoints import face_triangles, needs_face_collision
from clothtool.solver.penetration import barycentric_grid, face_penetration, round_cone_distance
from tests.physics.test_collision import (
    THICKNESS,
    capsule,
    capsule_distance,
    cloth_fabric,
    max_speed,
    merge,
    run,
    solver_for,
    spheres,
)

# the measure's sampling error for these faces (spacing^2 / (8 (r - depth)), spacing = edge / 162;
# under 25 micrometres for the 0.28 m hypotenuse against 1.5 cm) plus float32 input
TOLERANCE = 3e-5


def flat_triangle(size: float, height: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """One triangle in the plane y = height, corners (0,0), (size,0), (0,size) in (x, z)."""
    points = np.array([[0.0, height, 0.0], [size, height, 0.0], [0.0, height, size]], np.float32)
    return points, np.array([[0, 1, 2]], np.int32)


# ------------------------------------------------------------------ the measure
@pytest.mark.parametrize("depth", [0.0005, 0.003, 0.01])
@pytest.mark.parametrize("where", [(0.03, 0.02), (0.011, 0.047), (0.05, 0.05)])  # inside, inside, on the hypotenuse
def test_a_sphere_pressed_into_a_flat_triangle(depth, where):
    """A sphere of radius r whose centre is r - d above a point of the triangle: depth d."""
    points, triangles = flat_triangle(0.1)
    r = 0.05
    centre = [where[0], r - depth, where[1]]
    result = face_penetration(points, triangles, spheres([centre], r), 1.0, THICKNESS)
    assert result.depth == pytest.approx(depth, abs=TOLERANCE)
    assert result.faces_beyond == int(depth > THICKNESS)


def test_a_capsule_lying_across_a_triangle():
    """A horizontal capsule whose axis is r - d above the triangle's plane, crossing it: depth d."""
    points, triangles = flat_triangle(0.1)
    r, d = 0.03, 0.004
    result = face_penetration(points, triangles, capsule((-0.1, r - d, 0.04), (0.2, r - d, 0.01), (r, r)), 1.0, THICKNESS)
    assert result.depth == pytest.approx(d, abs=TOLERANCE)
    assert result.faces_beyond == 1


def test_a_tapered_capsule_sinks_by_its_larger_radius():
    """The lowest point of the hull of two spheres is the lower of the spheres' lowest points:
    with a horizontal axis at height h above the plane, the depth is max(ra, rb) - h."""
    points, triangles = flat_triangle(0.2)
    ra, rb, h = 0.03, 0.05, 0.045
    result = face_penetration(points, triangles, capsule((0.02, h, 0.05), (0.12, h, 0.05), (ra, rb)), 1.0, THICKNESS)
    assert result.depth == pytest.approx(max(ra, rb) - h, abs=TOLERANCE)


def test_a_face_outside_reports_minus_its_clearance():
    points, triangles = flat_triangle(0.1)
    r, gap = 0.04, 0.006
    result = face_penetration(points, triangles, spheres([[0.03, r + gap, 0.03]], r), 1.0, THICKNESS)
    assert result.depth == pytest.approx(-gap, abs=TOLERANCE)
    assert result.faces_beyond == 0


def test_far_faces_and_no_colliders():
    points, triangles = flat_triangle(0.1)
    assert face_penetration(points, triangles, spheres([[5.0, 5.0, 5.0]], 0.1), 1.0, THICKNESS).depth == -np.inf
    assert face_penetration(points, triangles, ColliderArrays(), 1.0, THICKNESS).depth == -np.inf


def test_faces_beyond_counts_triangles_and_units_scale():
    """Two triangles (scene units of 1 cm): one 5 mm deep in a sphere, one 1 mm deep in another."""
    first, _ = flat_triangle(10.0)
    second = first + [100.0, 0.0, 0.0]
    points = np.concatenate([first, second])
    triangles = np.array([[0, 1, 2], [3, 4, 5]], np.int32)
    colliders = spheres([[3.0, 5.0 - 0.5, 3.0], [103.0, 5.0 - 0.1, 3.0]], 5.0)
    result = face_penetration(points, triangles, colliders, 0.01, THICKNESS)
    assert result.depth == pytest.approx(0.005, abs=TOLERANCE)
    assert result.faces_beyond == 1


def test_round_cone_distance_matches_the_swept_spheres_outside():
    """Outside a round cone the distance is the smallest |p - c(s)| - r(s) over the spheres
    swept along the axis (tests.physics.test_collision.capsule_distance)."""
    rng = np.random.default_rng(3)
    a, b, ra, rb = np.array([0.1, 0.0, -0.2]), np.array([-0.2, 0.3, 0.1]), 0.08, 0.03
    p = rng.uniform(-0.6, 0.6, (400, 3))
    reference = capsule_distance(p, a, b, ra, rb)
    outside = reference > 0
    assert outside.sum() > 300
    ours = round_cone_distance(p, a, b, np.float64(ra), np.float64(rb))
    np.testing.assert_allclose(ours[outside], reference[outside], atol=1e-6)


def test_round_cone_distance_inside_a_cylinder():
    """Inside a capsule of equal radii, away from the caps: r - distance to the axis."""
    a, b, r = np.zeros(3), np.array([0.0, 0.0, 1.0]), 0.1
    p = np.array([[0.03, 0.04, 0.5], [0.0, -0.09, 0.3]])
    np.testing.assert_allclose(round_cone_distance(p, a, b, np.float64(r), np.float64(r)), [-0.05, -0.01], atol=1e-12)


def test_grids_are_barycentric():
    for level in (1, 3, 6):
        grid = barycentric_grid(level)
        assert grid.shape == ((level + 1) * (level + 2) // 2, 3)
        np.testing.assert_allclose(grid.sum(axis=1), 1.0)


# ------------------------------------------------------------------ the faces that collide
def test_faces_collide_where_the_bulge_exceeds_the_margin():
    """A right triangle with 5 cm legs (circumradius 35.4 mm): over a 2 cm rod with a 2 mm
    margin the hole sqrt(2 R t) is 9.4 mm, so it collides as a face; a 1 m sphere's is 63 mm
    and its corners hold it off alone; so do a 1.2 cm triangle's (8.5 mm) over the rod."""
    points, triangles = flat_triangle(0.05)
    assert needs_face_collision(points, triangles, 0.02, 0.002).tolist() == [True]
    assert needs_face_collision(points, triangles, 1.0, 0.002).tolist() == [False]
    small, _ = flat_triangle(0.012)
    assert needs_face_collision(small, triangles, 0.02, 0.002).tolist() == [False]
    both = np.concatenate([small, points])
    two = np.array([[0, 1, 2], [3, 4, 5]], np.int32)
    assert face_triangles(both, two, 0.02, 0.002).tolist() == [[3, 4, 5]]


# ------------------------------------------------------------------ a sheet on a thin rod
ROD = ((-0.6, 0.0, -0.25), (0.6, 0.0, 0.25))  # diagonal to the grid's edges
ROD_RADIUS = 0.02


def drape(face_collision: bool) -> list:
    """A 0.75 m sheet of 5 cm edges falls on a 2 cm rod; per frame the face penetration."""
    fabric = cloth_fabric(16, 0.75, 0.05)
    colliders = capsule(*ROD, (ROD_RADIUS, ROD_RADIUS))
    solver = solver_for(fabric, colliders, SolverConfig(face_collision=face_collision))
    depths = []
    for frame in range(20):
        run(solver, 1, first=frame)
        depths.append(face_penetration(solver.world_points(), fabric.triangles, colliders, 1.0, THICKNESS))
    return depths


def test_particle_collision_alone_lets_faces_into_a_thin_rod():
    depths = drape(face_collision=False)
    assert max(d.depth for d in depths) > 2 * THICKNESS
    assert max(d.faces_beyond for d in depths) > 0


def test_face_collision_keeps_every_face_within_the_thickness():
    depths = drape(face_collision=True)
    assert all(d.faces_beyond == 0 for d in depths), [d.faces_beyond for d in depths]
    assert max(d.depth for d in depths) <= THICKNESS
    assert max(d.depth for d in depths) > -3 * THICKNESS  # it does drape on the rod


def test_no_face_collision_with_continuous_collision():
    """Continuous collision is for colliders crossing the cloth faster than their width per
    iteration, which would push discretely collided faces out their far side: particles alone then."""
    fabric = cloth_fabric(16, 0.75, 0.05)
    colliders = capsule(*ROD, (ROD_RADIUS, ROD_RADIUS))
    stages = {}
    for continuous in (False, True):
        solver = solver_for(fabric, colliders, SolverConfig(continuous_collision=continuous))
        run(solver, 1)
        stages[continuous] = solver.stages[solver.stage_names.index("collide")]
    assert stages[False].faces.shape[0] == fabric.triangles.shape[0]  # 5 cm edges over a 2 cm rod
    assert stages[True].faces.shape[0] == 0
    assert stages[False].virtual.shape[0] == stages[True].virtual.shape[0] == 0  # faces add no virtual particles


# ------------------------------------------------------------------ a coarse sheet on two thin rods
@pytest.mark.parametrize("precision", ["float64", "float32"])
def test_a_coarse_sheet_hangs_on_rods_between_its_particles(precision):
    """A 60 cm sheet of only 3 x 3 particles (30 cm edges) falls onto two 1 cm rods that run
    under the middle of its faces, between its particle rows: no particle ever touches a rod,
    so particle collision alone lets the sheet fall through; each face's deepest point holds
    it, and within the cloth's thickness of the rods' surfaces, however large the faces."""
    fabric = cloth_fabric(3, 0.6, 0.05)
    rods = [((-0.5, 0.0, z), (0.5, 0.0, z)) for z in (-0.15, 0.15)]
    colliders = merge(*(capsule(a, b, (0.01, 0.01)) for a, b in rods))
    highest = {}
    for faces in (False, True):
        config = SolverConfig(face_collision=faces, precision=precision)
        solver = solver_for(fabric, colliders, config)
        depths = []
        for frame in range(30):
            run(solver, 1, first=frame)
            depths.append(face_penetration(solver.world_points(), fabric.triangles, colliders, 1.0, THICKNESS).depth)
        highest[faces] = float(solver.world_points()[:, 1].max())
        if faces:
            assert max(depths) <= THICKNESS, max(depths)
            assert np.isfinite(solver.world_points()).all() and max_speed(solver) < 1.0
    assert highest[False] < -0.5  # every particle fell past the rods
    assert highest[True] > -0.1  # the sheet hangs on them
