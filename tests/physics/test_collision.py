"""Collision with scene colliders: cloth at rest on spheres, capsules, boxes and tables; a thin
capsule sweeping through a cloth at 20 m/s; Coulomb friction on an incline; sub-step
interpolation of collider poses; virtual particles; a cloth simulated in a moving frame.

Distances to the colliders are measured with numpy from the geometry, not with the solver's
kernels. Margins: every collider here has thickness 0, so a particle's margin is the cloth
material's thickness (2 mm).
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from clothtool.collision.colliders import ColliderArrays
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.mesh.shapes import grid
from clothtool.profile import StageProfiler
from clothtool.settings import Material, Placement, SolverConfig
from clothtool.solver.cloth import ClothSolver
from clothtool.solver.environment import Environment
from clothtool.solver.frame import Pose
from clothtool.solver.model import build_model
from tests.physics.conftest import fabric_from_arrays

G = 9.81
GRAVITY = np.array([0.0, -G, 0.0])
FPS = 30.0
THICKNESS = 0.002  # m: the cloth material's thickness, the collision margin here
PENETRATION = 1e-4  # m: how far inside the margin a particle may end up
SPHERE_FIELDS = ("sphere_center", "sphere_radius", "sphere_margin", "sphere_friction", "sphere_is_collider")
# particle contact alone: tests of where particles rest (faces are held off by their own
# collision points otherwise, lifting the particles; see tests/physics/test_face_collision.py)
PARTICLES = SolverConfig(face_collision=False)
MESH_FIELDS = ("mesh_points", "mesh_triangles", "triangle_mesh", "mesh_margin", "mesh_friction")


def f32(x) -> np.ndarray:
    return np.asarray(x, np.float32)


# ------------------------------------------------------------------ colliders by hand
def spheres(centres, radii, friction=0.5) -> ColliderArrays:
    centres = f32(centres).reshape(-1, 3)
    n = centres.shape[0]
    return ColliderArrays(
        sphere_center=centres, sphere_radius=f32(np.broadcast_to(radii, n)), sphere_margin=np.zeros(n, np.float32),
        sphere_friction=np.full(n, friction, np.float32), sphere_is_collider=np.ones(n, bool),
    )


def capsule(start, end, radii, friction=0.5) -> ColliderArrays:
    one = np.ones(1, np.float32)
    return ColliderArrays(
        sphere_center=f32([start, end]), sphere_radius=f32(radii), sphere_margin=np.zeros(2, np.float32),
        sphere_friction=np.full(2, friction, np.float32), sphere_is_collider=np.zeros(2, bool),
        capsule_spheres=np.array([[0, 1]], np.int32), capsule_margin=0 * one, capsule_friction=friction * one,
    )


def box_planes(lo, hi) -> np.ndarray:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return f32([(*n, n @ (hi if n.sum() > 0 else lo)) for n in np.vstack([np.eye(3), -np.eye(3)])])


def convex(planes, friction=0.5) -> ColliderArrays:
    planes = f32(planes).reshape(-1, 4)
    one = np.ones(1, np.float32)
    return ColliderArrays(
        plane=planes, convex_plane_offsets=np.array([0, planes.shape[0]], np.int32), convex_margin=0 * one,
        convex_friction=friction * one,
    )


def box_mesh(lo, hi, cells: int) -> ColliderArrays:
    """A closed box of 6 * 2 * cells^2 triangles, outward (counter-clockwise) winding."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    points, triangles = [], []
    g = np.linspace(0.0, 1.0, cells + 1)
    a, b = np.meshgrid(g, g, indexing="ij")
    for axis in range(3):
        for sign in (-1, 1):
            u, v = (axis + 1) % 3, (axis + 2) % 3
            if sign < 0:
                u, v = v, u
            face = np.zeros((cells + 1, cells + 1, 3))
            face[..., axis] = hi[axis] if sign > 0 else lo[axis]
            face[..., u] = lo[u] + a * (hi[u] - lo[u])
            face[..., v] = lo[v] + b * (hi[v] - lo[v])
            index = np.arange((cells + 1) ** 2).reshape(cells + 1, cells + 1) + sum(len(p) for p in points)
            q0, q1, q2, q3 = index[:-1, :-1].ravel(), index[1:, :-1].ravel(), index[1:, 1:].ravel(), index[:-1, 1:].ravel()
            triangles += [np.stack([q0, q1, q2], 1), np.stack([q0, q2, q3], 1)]
            points.append(face.reshape(-1, 3))
    points, triangles = np.concatenate(points), np.concatenate(triangles).astype(np.int32)
    normal = np.cross(points[triangles[:, 1]] - points[triangles[:, 0]], points[triangles[:, 2]] - points[triangles[:, 0]])
    assert (np.einsum("ij,ij->i", normal, points[triangles].mean(1) - (lo + hi) / 2) > 0).all()
    one = np.ones(1, np.float32)
    return ColliderArrays(
        mesh_points=f32(points), mesh_triangles=triangles, triangle_mesh=np.zeros(len(triangles), np.int32),
        mesh_margin=0 * one, mesh_friction=0.5 * one,
    )


def merge(*parts: ColliderArrays) -> ColliderArrays:
    """One ColliderArrays holding all of ``parts`` (indices offset)."""
    def cat(name):
        return np.concatenate([getattr(p, name) for p in parts])

    spheres_before = np.cumsum([0] + [p.sphere_center.shape[0] for p in parts[:-1]])
    points_before = np.cumsum([0] + [p.mesh_points.shape[0] for p in parts[:-1]])
    planes_before = np.cumsum([0] + [p.plane.shape[0] for p in parts[:-1]])
    meshes_before = np.cumsum([0] + [p.mesh_margin.shape[0] for p in parts[:-1]])
    return ColliderArrays(
        sphere_center=cat("sphere_center"), sphere_radius=cat("sphere_radius"), sphere_margin=cat("sphere_margin"),
        sphere_friction=cat("sphere_friction"), sphere_is_collider=cat("sphere_is_collider"),
        capsule_spheres=np.concatenate([p.capsule_spheres + o for p, o in zip(parts, spheres_before)]).astype(np.int32),
        capsule_margin=cat("capsule_margin"), capsule_friction=cat("capsule_friction"), plane=cat("plane"),
        convex_plane_offsets=np.concatenate(
            [[0]] + [p.convex_plane_offsets[1:] + o for p, o in zip(parts, planes_before)]
        ).astype(np.int32),
        convex_margin=cat("convex_margin"), convex_friction=cat("convex_friction"), mesh_points=cat("mesh_points"),
        mesh_triangles=np.concatenate([p.mesh_triangles + o for p, o in zip(parts, points_before)]).astype(np.int32),
        triangle_mesh=np.concatenate([p.triangle_mesh + o for p, o in zip(parts, meshes_before)]).astype(np.int32),
        mesh_margin=cat("mesh_margin"), mesh_friction=cat("mesh_friction"),
    )


# ------------------------------------------------------------------ distances (numpy)
def box_distance(points, lo, hi) -> np.ndarray:
    centre, half = (np.asarray(lo) + hi) / 2, (np.asarray(hi) - lo) / 2
    q = np.abs(np.asarray(points, float) - centre) - half
    return np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0)


def capsule_distance(points, a, b, ra, rb) -> np.ndarray:
    """min over the interpolated spheres of |p - c| - r: the distance outside, < 0 inside."""
    s = np.linspace(0, 1, 2001)[:, None]
    centres = (1 - s) * np.asarray(a, float) + s * np.asarray(b, float)
    radii = (1 - s[:, 0]) * ra + s[:, 0] * rb
    p = np.asarray(points, float)
    return np.min(np.linalg.norm(p[:, None] - centres[None], axis=2) - radii[None], axis=1)


# ------------------------------------------------------------------ solvers
def cloth_fabric(n: int, size: float, height: float, **options):
    mesh = grid(n, n, size / (n - 1), plane="XZ", origin=(-size / 2, height, -size / 2))
    return cook_fabric(mesh, CookOptions(**options)).fabric


def solver_for(fabric, colliders, config=SolverConfig(), material=Material(thickness=THICKNESS), **kwargs) -> ClothSolver:
    call = colliders if callable(colliders) else (lambda t: colliders)
    model = build_model("cloth", fabric, material, Placement(), 1.0, "Y")
    solver = ClothSolver(model, config, Environment(GRAVITY, colliders=call), StageProfiler(), **kwargs)
    assert "collide" in solver.stage_names
    return solver


def run(solver: ClothSolver, frames: int, fps: float = FPS, first: int = 0) -> None:
    for frame in range(first, first + frames):
        solver.step(frame, frame / fps, 1.0 / fps)


def max_speed(solver: ClothSolver) -> float:
    h = 1.0 / solver.config.frequency
    return float(np.linalg.norm(solver.world_velocities(h), axis=1).max())


# ------------------------------------------------------------------ at rest on colliders
def test_cloth_rests_on_a_sphere():
    fabric = cloth_fabric(16, 0.8, 0.32)
    solver = solver_for(fabric, spheres([[0, 0, 0]], 0.3), PARTICLES)
    run(solver, 75)
    points = solver.world_points().astype(float)
    distance = np.linalg.norm(points, axis=1) - 0.3
    assert distance.min() >= THICKNESS - PENETRATION, distance.min()
    assert distance.min() <= THICKNESS + 1e-4  # it does lie on the sphere
    assert max_speed(solver) < 0.02


def test_cloth_rests_on_a_tapered_capsule():
    a, b, ra, rb = (-0.3, 0.0, 0.0), (0.3, 0.0, 0.0), 0.12, 0.06
    fabric = cloth_fabric(16, 0.8, 0.15)
    solver = solver_for(fabric, capsule(a, b, (ra, rb)), PARTICLES)
    run(solver, 75)
    distance = capsule_distance(solver.world_points(), a, b, ra, rb)
    assert distance.min() >= THICKNESS - PENETRATION, distance.min()
    assert distance.min() <= THICKNESS + 1e-4
    assert max_speed(solver) < 0.02


def test_cloth_rests_on_a_box():
    lo, hi = (-0.2, -0.3, -0.15), (0.2, 0.0, 0.15)
    fabric = cloth_fabric(16, 0.7, 0.04)
    solver = solver_for(fabric, convex(box_planes(lo, hi)))
    run(solver, 75)
    distance = box_distance(solver.world_points(), lo, hi)
    assert distance.min() >= THICKNESS - PENETRATION, distance.min()
    assert max_speed(solver) < 0.02
    # it drapes: the middle lies on the top, the corners hang over the sides
    assert distance.min() <= THICKNESS + 1e-4
    assert solver.world_points()[:, 1].min() < -0.1


@pytest.mark.parametrize("config, still", [(PARTICLES, 0.02), (SolverConfig(), 0.1)], ids=["particles", "faces"])
def test_cloth_rests_on_a_table_mesh(config, still):
    """With face collision (the table's edges against the faces folded over them) the cloth
    keeps a residual jitter of a few cm/s at the edges: an open issue of the mesh face contacts."""
    lo, hi = (-0.25, -0.5, -0.2), (0.25, 0.0, 0.2)
    table = box_mesh(lo, hi, 4)
    fabric = cloth_fabric(20, 0.8, 0.05)
    solver = solver_for(fabric, table, config)
    run(solver, 75)
    distance = box_distance(solver.world_points(), lo, hi)
    assert distance.min() >= THICKNESS - PENETRATION, distance.min()
    assert max_speed(solver) < still
    points = solver.world_points()
    assert points[:, 1].min() < -0.1  # draped over the edges, not stuck above them


def test_without_the_stage_the_cloth_falls_through():
    """The resting tests can fail: with no colliders the same cloth falls past the sphere."""
    fabric = cloth_fabric(16, 0.8, 0.32)
    model = build_model("cloth", fabric, Material(), Placement(), 1.0, "Y")
    solver = ClothSolver(model, SolverConfig(), Environment(GRAVITY), StageProfiler())
    assert "collide" not in solver.stage_names
    # 7 frames: a free cloth falls freely (its damping spares its mean motion), 0.27 m by then,
    # so its middle is inside the sphere (after 15 frames it would have fallen right through)
    run(solver, 7)
    assert (np.linalg.norm(solver.world_points(), axis=1) < 0.25).sum() > 50  # inside the sphere


# ------------------------------------------------------------------ continuous collision
@pytest.fixture(scope="module")
def curtain():
    """A 1 m curtain of 32 x 32 particles hanging in the XY plane, pinned along its top row."""
    return cook_fabric(grid(32, 32, 1.0 / 31, plane="XY"), CookOptions(pin_box=(-1, -1e-3, -1, 2, 1e-3, 1))).fabric


SWEEP_RADIUS = 0.005  # m: a 1 cm thick capsule
SWEEP_SPEED = 20.0  # m/s along +z
SWEEP_HEIGHT = -15.0 / 31.0  # the height of row 15 of the curtain
SWEEP_START = -0.1  # z at t = 0


def sweep(t: float) -> ColliderArrays:
    z = SWEEP_START + SWEEP_SPEED * t
    return capsule((-0.5, SWEEP_HEIGHT, z), (1.5, SWEEP_HEIGHT, z), (SWEEP_RADIUS, SWEEP_RADIUS))


@pytest.mark.parametrize("continuous", [True, False])
def test_thin_fast_capsule_does_not_tunnel_with_continuous_collision(curtain, continuous):
    """A capsule 1 cm thick crosses the curtain at 20 m/s: 6.7 cm per iteration at 300 Hz, so
    at no iteration's end is a particle within its reach. Its path plane (y = row 15's height,
    swept along z) holds the particles of row 15; after the sweep every one of them must be on
    the capsule's far side of its start (pushed along, z beyond the capsule's back), none
    left behind it. Without continuous collision they are all left behind."""
    # particles only, as with continuous collision; without it, the control, too
    config = SolverConfig(frequency=300.0, continuous_collision=continuous, face_collision=False)
    solver = solver_for(curtain, sweep, config)
    fps = 60.0
    run(solver, 2, fps)  # the capsule travels 0.67 m, the curtain hangs at z = 0
    capsule_z = SWEEP_START + SWEEP_SPEED * 2 / fps
    points = solver.world_points()
    rest = solver.model.rest_pos
    in_path = np.abs(rest[:, 1] - SWEEP_HEIGHT) < SWEEP_RADIUS + THICKNESS
    in_path &= solver.model.inv_mass > 0
    assert in_path.sum() == 32
    behind = points[in_path, 2] < capsule_z - SWEEP_RADIUS
    if continuous:
        assert not behind.any(), points[in_path][behind]
        assert np.allclose(points[in_path, 2], capsule_z + SWEEP_RADIUS + THICKNESS, atol=1e-3)
    else:
        assert behind.all()  # the test can fail: discrete collision lets the capsule through


# ------------------------------------------------------------------ friction
def incline_run(degrees: float, mu: float, seconds: float = 0.5):
    """A particle resting on a plane tilted by ``degrees`` about z: its displacement down the
    slope after ``seconds``, and its height above the plane."""
    theta = np.radians(degrees)
    normal = np.array([-np.sin(theta), np.cos(theta), 0.0])
    down = np.array([-np.cos(theta), -np.sin(theta), 0.0])
    fabric = fabric_from_arrays(np.array([normal * THICKNESS]), [1.0])
    solver = solver_for(fabric, convex([[*normal, 0.0]], friction=mu), material=Material(thickness=THICKNESS, damping=0.0))
    start = solver.state.cur[0, :3].astype(float)
    run(solver, int(round(seconds * FPS)))
    position = solver.state.cur[0, :3].astype(float)
    return (position - start) @ down, position @ normal


@pytest.mark.parametrize("degrees", [15.0, 25.0])
def test_friction_holds_below_the_friction_angle(degrees):
    mu = 0.5  # friction angle atan(0.5) = 26.6 degrees
    slide, height = incline_run(degrees, mu)
    assert abs(slide) < 1e-5, slide
    assert abs(height - THICKNESS) < 1e-5


@pytest.mark.parametrize("degrees, mu", [(30.0, 0.5), (45.0, 0.5), (40.0, 0.2)])
def test_friction_slides_above_the_friction_angle_at_the_coulomb_rate(degrees, mu):
    seconds = 0.5
    slide, height = incline_run(degrees, mu, seconds)
    theta = np.radians(degrees)
    expected = G * (np.sin(theta) - mu * np.cos(theta))
    acceleration = 2 * slide / seconds**2
    assert abs(acceleration - expected) < 0.1 * expected, (acceleration, expected)
    assert abs(height - THICKNESS) < 1e-5


def test_cloth_on_an_incline_follows_coulomb():
    """A small cloth patch (all particles in contact) holds at 20 degrees and slides at 40
    degrees with mu = 0.5 at g (sin - mu cos)."""
    results = {}
    for degrees in (20.0, 40.0):
        theta = np.radians(degrees)
        normal = np.array([-np.sin(theta), np.cos(theta), 0.0])
        down = np.array([-np.cos(theta), -np.sin(theta), 0.0])
        rotation = Rotation.from_rotvec([0, 0, theta]).as_matrix()
        mesh = grid(5, 5, 0.05, plane="XZ", origin=(-0.1, 0.0, -0.1))
        fabric = cook_fabric(mesh).fabric
        model = build_model(
            "patch", fabric, Material(thickness=THICKNESS, damping=0.0),
            Placement(rotation=rotation, translation=normal * THICKNESS), 1.0, "Y",
        )
        plane = convex([[*normal, 0.0]], friction=0.5)
        solver = ClothSolver(model, SolverConfig(), Environment(GRAVITY, colliders=lambda t: plane), StageProfiler())
        start = solver.world_points().mean(axis=0)
        run(solver, 15)
        results[degrees] = 2 * (solver.world_points().mean(axis=0) - start) @ down / 0.5**2
    assert abs(results[20.0]) < 1e-3
    expected = G * (np.sin(np.radians(40)) - 0.5 * np.cos(np.radians(40)))
    assert abs(results[40.0] - expected) < 0.1 * expected, (results, expected)


# ------------------------------------------------------------------ interpolation
def test_collider_poses_are_interpolated_linearly_per_iteration():
    """Each iteration the stage sees the colliders at its start and end fractions of the frame,
    linear between the frame's start and end samples (planes renormalised)."""
    def colliders(t):
        sphere = spheres([[0.1 + t, 2 * t, -t]], 0.2 + t)
        n = np.array([np.sin(t), np.cos(t), 0.0])
        planes = f32([[*n, -1.0 + t]])
        mesh = box_mesh((-2 + t, -2, -2), (-1.5 + t, -1.5 + 3 * t, -1.5), 1)
        return ColliderArrays(
            **{k: getattr(sphere, k) for k in SPHERE_FIELDS},
            plane=planes, convex_plane_offsets=np.array([0, 1], np.int32), convex_margin=np.zeros(1, np.float32),
            convex_friction=np.ones(1, np.float32),
            **{k: getattr(mesh, k) for k in MESH_FIELDS},
        )

    fabric = cloth_fabric(4, 0.2, 5.0)
    solver = solver_for(fabric, colliders)
    stage = solver.stages[solver.stage_names.index("collide")]
    frame, time, dt = 3, 0.5, 1.0 / 30.0
    plan = solver.plan_frame(frame, time, dt)
    a, b = colliders(time), colliders(time + dt)

    def lerp(x, y, alpha):
        return np.asarray(x, float) + alpha * (np.asarray(y, float) - np.asarray(x, float))

    assert plan.iterations == 10
    for j in range(plan.iterations):
        iteration = solver.iteration(plan, j)
        solver.iterate(iteration)
        ends = ((j / 10, stage.sphere_start, stage.mesh_start), ((j + 1) / 10, stage.sphere_end, stage.mesh_end))
        for alpha, sphere, mesh in ends:
            np.testing.assert_allclose(sphere[:, :3], lerp(a.sphere_center, b.sphere_center, alpha), atol=1e-6)
            np.testing.assert_allclose(sphere[:, 3], lerp(a.sphere_radius, b.sphere_radius, alpha), atol=1e-6)
            np.testing.assert_allclose(mesh, lerp(a.mesh_points, b.mesh_points, alpha), atol=1e-6)
        plane = lerp(a.plane, b.plane, (j + 1) / 10)
        np.testing.assert_allclose(stage.plane_end, plane / np.linalg.norm(plane[:, :3]), atol=1e-6)
        # the packed records the kernels read carry the same poses, plus the margin
        posed = np.concatenate([stage.sphere_start[0], stage.sphere_end[0]]) + [0, 0, 0, THICKNESS] * 2
        np.testing.assert_allclose(stage.sphere_data[0, :8], posed, atol=1e-6)


def test_colliders_are_taken_into_a_moving_frame():
    """With a track, the stage's geometry is the world geometry in the frame's coordinates:
    the start with the frame's pose at the iteration's start, the end with it at the end."""
    def track(t):
        return Pose(Rotation.from_rotvec([0.0, 0.4 + t, 0.1]).as_matrix(), np.array([1.0 + t, 0.5, -2 * t]))

    sphere = spheres([[0.3, 0.2, 0.1]], 0.1)
    solver = solver_for(cloth_fabric(4, 0.2, 5.0), sphere, track=track)
    stage = solver.stages[solver.stage_names.index("collide")]
    plan = solver.plan_frame(0, 0.0, 1.0 / 30.0)
    for j in range(plan.iterations):
        solver.iterate(solver.iteration(plan, j))
        before = track(j * plan.h)
        now = track((j + 1) * plan.h)
        np.testing.assert_allclose(stage.sphere_start[0, :3], before.to_local(sphere.sphere_center)[0], atol=1e-6)
        np.testing.assert_allclose(stage.sphere_end[0, :3], now.to_local(sphere.sphere_center)[0], atol=1e-6)


# ------------------------------------------------------------------ virtual particles
@pytest.mark.parametrize("virtual", [4, 0])
def test_virtual_particles_catch_a_small_sphere(virtual):
    """A 4 x 4-quad cloth 1 m wide falls on a sphere of radius 5 cm under the middle of one
    triangle (25 cm legs): no particle touches it. With 4 virtual particles per triangle the
    triangle stays on top of the sphere; without them the sphere goes through the cloth."""
    fabric = cook_fabric(grid(5, 5, 0.25, plane="XZ", origin=(-0.5, 0.1, -0.5)), CookOptions(virtual_particles=virtual)).fabric
    assert fabric.virtual_particles.shape[0] == 32 * virtual
    centroids = fabric.rest_pos[fabric.triangles].mean(axis=1)
    triangle = fabric.triangles[np.argmin(np.linalg.norm(centroids[:, [0, 2]] - [0.08, -0.08], axis=1))]
    centre = fabric.rest_pos[triangle].mean(axis=0) * [1, 0, 1]
    # face collision off: the cooked virtual particles alone decide
    solver = solver_for(fabric, spheres([centre], 0.05), PARTICLES)
    run(solver, 15)
    corners = solver.world_points()[triangle].astype(float)
    # the height of the triangle's plane above the sphere's centre, along the vertical
    normal = np.cross(corners[1] - corners[0], corners[2] - corners[0])
    height = corners[0, 1] + (normal[[0, 2]] @ (corners[0, [0, 2]] - centre[[0, 2]])) / normal[1] - centre[1]
    if virtual:
        assert height > 0.05, height
    else:
        assert solver.world_points()[:, 1].max() < -0.05  # fell past it


# ------------------------------------------------------------------ moving frames
def test_cloth_in_a_moving_frame_collides_with_a_world_sphere():
    """A cloth simulated in a translating, rotated frame lands on a world-space sphere exactly
    as the same cloth simulated in world space (same start, same velocity), and keeps its
    margin from it. Undamped: damping acts on velocity relative to the cloth's frame, so only
    without it are the two runs the same physics."""
    fabric = cloth_fabric(12, 0.4, 0.0)
    rotation = Rotation.from_rotvec([0, np.radians(30), 0]).as_matrix()
    origin, velocity = np.array([-0.3, 0.25, 0.1]), np.array([0.6, 0.0, 0.0])
    ball = spheres([[0.0, 0.0, 0.1]], 0.12, friction=0.4)

    def track(t):
        return Pose(rotation.copy(), origin + velocity * t)

    material = Material(thickness=THICKNESS, damping=0.0)
    local = solver_for(fabric, ball, PARTICLES, material=material, track=track)
    placement = Placement(rotation=rotation, translation=origin)
    model = build_model("cloth", fabric, material, placement, 1.0, "Y")
    environment = Environment(GRAVITY, colliders=lambda t: ball)
    world = ClothSolver(model, PARTICLES, environment, StageProfiler(), initial_velocity=velocity)
    closest = []
    for frame in range(20):
        local.step(frame, frame / FPS, 1 / FPS)
        world.step(frame, frame / FPS, 1 / FPS)
        points = local.world_points().astype(float)
        np.testing.assert_allclose(points, world.world_points(), atol=5e-4)
        closest.append(np.linalg.norm(points - [0.0, 0.0, 0.1], axis=1).min() - 0.12)
    assert min(closest) >= THICKNESS - PENETRATION
    assert min(closest) < THICKNESS + 1e-4  # it did land on the sphere


# ------------------------------------------------------------------ memory
def test_the_stage_does_not_allocate_per_iteration():
    """Once a frame has begun, iterations reuse the stage's arrays: with a moving 1728-triangle
    mesh, spheres, a capsule and a box (any per-iteration copy of the mesh records alone would
    be 220 kB), running every iteration of a frame allocates next to nothing."""
    def colliders(t):
        return merge(
            spheres([[0.3, -0.1 + t, 0.0]], 0.1), capsule((-0.3, 0.0, 0.3), (0.3, 0.0, 0.3), (0.05, 0.04)),
            convex(box_planes((-0.4, -0.3, -0.4), (-0.2, -0.1, -0.2))),
            box_mesh((-0.3, -1.0 + t, -0.3), (0.3, -0.2 + t, 0.3), 12),
        )

    fabric = cloth_fabric(16, 0.8, 0.0, virtual_particles=4)
    solver = solver_for(fabric, colliders, SolverConfig(continuous_collision=True))
    assert colliders(0.0).mesh_triangles.shape[0] == 1728
    run(solver, 6)
    stage = solver.stages[solver.stage_names.index("collide")]
    plan = solver.plan_frame(6, 6 / FPS, 1 / FPS)
    iterations = [solver.iteration(plan, j) for j in range(plan.iterations)]
    stage.run(iterations[0])
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        for iteration in iterations[1:]:
            stage.run(iteration)
        current, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak - base < 20_000, peak - base
    assert current - base < 4_000, current - base


def test_warm_up_compiles_everything_a_frame_uses():
    """After warm_up, simulating with every collider kind, continuous collision, virtual
    particles and a moving frame compiles nothing new (the bake times warm-up apart)."""
    from numba.core.registry import CPUDispatcher

    from clothtool.solver.kernels import collide, collide_mesh, collide_pose, collide_shapes

    def colliders(t):
        return merge(
            spheres([[0.3, -0.1 + t, 0.0]], 0.1), capsule((-0.3, 0.0, 0.3), (0.3, 0.0, 0.3), (0.05, 0.04)),
            convex(box_planes((-0.4, -0.3, -0.4), (-0.2, -0.1, -0.2))), box_mesh((-0.3, -1.0 + t, -0.3), (0.3, -0.2 + t, 0.3), 2),
        )

    def track(t):
        return Pose(Rotation.from_rotvec([0.0, t, 0.0]).as_matrix(), np.array([0.1 * t, 0.0, 0.0]))

    fabric = cloth_fabric(8, 0.6, 0.0, virtual_particles=4)
    solver = solver_for(fabric, colliders, SolverConfig(continuous_collision=True), track=track)
    solver.warm_up()
    dispatchers = [
        obj for module in (collide, collide_mesh, collide_pose, collide_shapes)
        for obj in vars(module).values() if isinstance(obj, CPUDispatcher)
    ]
    before = {d: len(d.signatures) for d in dispatchers}
    run(solver, 3)
    assert {d: len(d.signatures) for d in dispatchers} == before


def test_float64_state_collides_like_float32():
    """Study references simulate in float64: the stage follows the state's precision."""
    lo, hi = (-0.2, -0.3, -0.15), (0.2, 0.0, 0.15)
    fabric = cloth_fabric(10, 0.6, 0.04)
    points = {}
    for precision in ("float32", "float64"):
        solver = solver_for(fabric, merge(convex(box_planes(lo, hi)), spheres([[0.2, 0.0, 0.0]], 0.05)),
                            SolverConfig(precision=precision, continuous_collision=True))
        run(solver, 20)
        assert solver.state.cur.dtype == np.dtype(precision)
        points[precision] = solver.world_points().astype(float)
        assert box_distance(points[precision], lo, hi).min() >= THICKNESS - PENETRATION
    np.testing.assert_allclose(points["float32"], points["float64"], atol=2e-3)
