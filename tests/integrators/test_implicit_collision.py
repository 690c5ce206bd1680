"""Collision handling of the implicit integrator: distances and impulses against
tests/reference/implicit_collision.py, strain limiting against
tests/reference/implicit_strain.py, and cloths meeting colliders."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.integrators.implicit.collision import pack_colliders
from clothtool.integrators.implicit.kernels.implicit_collision import (
    NO_CONTACT,
    collide_particles,
    end_contacts,
    nearest_contacts,
    project_particles,
)
from clothtool.integrators.implicit.kernels.implicit_strain import limit_strain
from clothtool.integrators.implicit.pattern import color_elements, triangle_edges
from clothtool.settings import load_material
from clothtool.solver.colliders import ColliderArrays
from tests.integrators.test_implicit_setup import grid_fabric, make_solver, replace, run
from tests.reference import implicit_collision as ref
from tests.reference import implicit_strain as ref_strain

F32 = np.float32


def scene_colliders(shift=(0.0, 0.0, 0.0), grow=0.0) -> ColliderArrays:
    """A sphere, a tapered capsule (two capsule-only end spheres), a box convex, a ground
    plane convex and a tetrahedron mesh, moved by ``shift`` and grown by ``grow``."""
    s = np.asarray(shift, np.float32)
    box = [[1, 0, 0, 3.5], [-1, 0, 0, -2.5], [0, 1, 0, 0.5], [0, -1, 0, 0.5], [0, 0, 1, 0.5], [0, 0, -1, 0.5]]
    planes = np.array(box + [[0, 1, 0, -2.0]], np.float32)
    planes[:, 3] += planes[:, :3] @ s
    tetra = np.array([[5, 0, 0], [6, 0, 0], [5, 1, 0], [5, 0, 1]], np.float32) + s
    return ColliderArrays(
        sphere_center=np.array([[0, 0, 0], [-3, 0, 0], [-3, 1.5, 0.5]], np.float32) + s,
        sphere_radius=np.array([0.5 + grow, 0.4, 0.15], np.float32),
        sphere_margin=np.array([0.01, 0, 0], np.float32),
        sphere_friction=np.array([0.3, 0, 0], np.float32),
        sphere_is_collider=np.array([True, False, False]),
        capsule_spheres=np.array([[1, 2]], np.int32),
        capsule_margin=np.array([0.02], np.float32),
        capsule_friction=np.array([0.4], np.float32),
        plane=planes,
        convex_plane_offsets=np.array([0, 6, 7], np.int32),
        convex_margin=np.array([0.0, 0.005], np.float32),
        convex_friction=np.array([0.6, 0.7], np.float32),
        mesh_points=tetra,
        mesh_triangles=np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.int32),
        triangle_mesh=np.zeros(4, np.int32),
        mesh_margin=np.array([0.01], np.float32),
        mesh_friction=np.array([0.2], np.float32),
    )


def near_points(rng, count=400):
    """Points around every collider, inside and outside."""
    centres = np.array([[0, 0, 0], [-3, 0.7, 0.2], [3, 0, 0], [0, -2.05, 0], [5.3, 0.3, 0.3]])
    spread = np.array([0.7, 0.8, 0.7, 0.1, 0.6])
    pick = rng.integers(0, len(centres), count)
    return centres[pick] + rng.normal(size=(count, 3)) * spread[pick, None]


def test_nearest_contact_matches_reference():
    rng = np.random.default_rng(0)
    start, end = scene_colliders(), scene_colliders(shift=(0.1, -0.2, 0.05), grow=0.05)
    h, radius = 0.04, 0.5
    _, packed = pack_colliders(start, end, h, radius)
    points = near_points(rng)
    contacts = np.zeros((points.shape[0], 8))
    nearest_contacts(packed, points, contacts)
    mesh_checked = 0
    for p, contact in zip(points, contacts):
        expected = ref.nearest_contact(start, end, h, p, mesh_radius=radius)
        near_mesh = ref.nearest_contact(start, end, h, p, mesh_radius=radius, only_mesh=True)[0] < NO_CONTACT
        # away from the mesh its grid answers nothing; next to it the grid cell may hold
        # triangles a little beyond the radius, so compare there only when the mesh wins
        if not near_mesh and np.linalg.norm(p - [5.3, 0.3, 0.3]) < 1.5 + radius:
            continue
        # near a mesh edge the inside/outside sign depends on which face is nearest
        if near_mesh and abs(expected[0]) < 1e-3:
            continue
        mesh_checked += near_mesh
        np.testing.assert_allclose(contact[0], expected[0], atol=1e-7, err_msg=str(p))
        np.testing.assert_allclose(contact[1:], expected[1:], atol=1e-5, err_msg=str(p))
    assert mesh_checked > 30


def test_mesh_crossing_catches_a_fast_particle():
    start = end = scene_colliders()
    _, packed = pack_colliders(start, end, 0.04, radius=0.01)
    rng = np.random.default_rng(3)
    # paths from outside the tetrahedron's x = 5 face to deep inside and beyond, and some
    # that stay outside
    p0 = np.column_stack([rng.uniform(4.6, 4.95, 60), rng.uniform(0.05, 0.4, 60), rng.uniform(0.05, 0.4, 60)])
    p1 = p0 + np.column_stack([rng.uniform(0.0, 0.8, 60), rng.normal(0, 0.05, 60), rng.normal(0, 0.05, 60)])
    out = np.zeros((60, 8))
    end_contacts(packed, p0, p1, out)
    expected = ref.end_contacts(start, end, 0.04, p0, p1, mesh_radius=0.01)
    np.testing.assert_allclose(out[:, :4], expected[:, :4], atol=1e-9)
    crossed = out[:, 0] < -0.05
    assert crossed.sum() > 10 and (out[:, 0] > 0).sum() > 5  # paths that stay outside
    np.testing.assert_allclose(out[crossed, 1:4], np.tile([-1.0, 0.0, 0.0], (crossed.sum(), 1)), atol=1e-12)


@pytest.mark.parametrize("seed", [0, 1])
def test_impulses_match_reference(seed):
    """Particles near the primitives (no meshes: the reference has no crossing test) with
    random average velocities: steps 1-3 then 4 against the reference."""
    rng = np.random.default_rng(seed)
    start = scene_colliders()
    end = scene_colliders(shift=(0.05, 0.02, 0.0), grow=0.02)
    start = ColliderArrays(**{**start.__dict__, "mesh_triangles": np.zeros((0, 3), np.int32), "triangle_mesh": np.zeros(0, np.int32)})
    end = ColliderArrays(**{**end.__dict__, "mesh_triangles": np.zeros((0, 3), np.int32), "triangle_mesh": np.zeros(0, np.int32)})
    h, thickness, stiffness = 0.04, 0.01, 500.0
    points = near_points(rng, 300)
    points = points[np.linalg.norm(points - [5.3, 0.3, 0.3], axis=1) > 1.5]
    n = points.shape[0]
    velocity = rng.normal(size=(n, 3)) * 1.5
    mass = rng.uniform(0.5, 2.0, n) * 1e-3
    free = (rng.random(n) > 0.1).astype(np.uint8)
    sets = pack_colliders(start, end, h, thickness)
    v_mid, v_end, contact = velocity.copy(), velocity.copy(), np.zeros((n, 8))
    collide_particles(*sets, points, mass, free, thickness, stiffness, h, 4, v_mid, v_end, contact)
    ref_mid, ref_end, ref_contact = ref.collide_particles(start, end, points, mass, free, thickness, stiffness, h, 4,
                                                          velocity, velocity)
    np.testing.assert_allclose(v_mid, ref_mid, atol=1e-6)
    np.testing.assert_allclose(v_end, ref_end, atol=1e-6)
    np.testing.assert_allclose(contact[free != 0], ref_contact[free != 0], atol=1e-6)
    project_particles(sets[1], points, free, thickness, h, v_mid, v_end, contact)
    ref_mid, ref_end, ref_contact = ref.project_particles(start, end, points, free, thickness, h, ref_mid, ref_end,
                                                          ref_contact)
    np.testing.assert_allclose(v_mid, ref_mid, atol=1e-6)
    np.testing.assert_allclose(v_end, ref_end, atol=1e-6)
    touched = ref_contact[:, 0] < NO_CONTACT
    np.testing.assert_array_equal(contact[:, 0] < NO_CONTACT, touched)
    assert 30 < touched.sum() < n  # both kinds are exercised
    assert np.all(v_mid[free == 0] == velocity[free == 0])


@pytest.mark.parametrize("seed", [0, 1])
def test_strain_limiting_matches_reference(seed):
    rng = np.random.default_rng(seed)
    fabric = grid_fabric(6)
    n = fabric.particle_count
    edges = triangle_edges(fabric.triangles, n)
    rest = fabric.rest_pos.astype(np.float64)
    rest_length = np.linalg.norm(rest[edges[:, 1]] - rest[edges[:, 0]], axis=1)
    order, offsets = color_elements(edges, n)
    inv_mass = rng.uniform(0.5, 2.0, n)
    inv_mass[[0, 5]] = 0.0
    h = 0.04
    v = rng.normal(size=(n, 3)) * 0.5
    out_mid, out_end = v.copy(), v.copy() + 1.0
    count = limit_strain(edges, rest_length, inv_mass, order, offsets, rest, h, 0.1, 50, out_mid, out_end)
    ref_mid, ref_end, ref_count = ref_strain.limit_strain(edges, rest_length, inv_mass, order, offsets, rest, h, 0.1, 50,
                                                          v, v + 1.0)
    assert count == ref_count > 0
    np.testing.assert_allclose(out_mid, ref_mid, atol=1e-12)
    np.testing.assert_allclose(out_end, ref_end, atol=1e-12)
    end = rest + h * out_mid
    lengths = np.linalg.norm(end[edges[:, 1]] - end[edges[:, 0]], axis=1)
    assert np.all(lengths <= 1.1 * rest_length * (1 + 1e-9))  # converged within 50 sweeps
    np.testing.assert_array_equal(out_mid[[0, 5]], v[[0, 5]])  # fixed ends do not move


# ----------------------------------------------------------------- cloths meeting colliders
def sphere(center, radius, margin, friction):
    one = np.ones(1, np.float32)
    arrays = ColliderArrays(
        sphere_center=np.asarray([center], np.float32), sphere_radius=radius * one, sphere_margin=margin * one,
        sphere_friction=friction * one, sphere_is_collider=np.ones(1, bool),
    )
    return lambda time: arrays


def ground(height, friction, margin=0.0):
    one = np.ones(1, np.float32)
    arrays = ColliderArrays(plane=np.array([[0, 1, 0, height]], np.float32), convex_plane_offsets=np.array([0, 1], np.int32),
                            convex_margin=margin * one, convex_friction=friction * one)
    return lambda time: arrays


@pytest.mark.parametrize("steps_per_frame", [1, 2])
def test_cloth_dropped_on_a_sphere_comes_to_rest_outside_it(steps_per_frame):
    """A 0.4 m cotton square dropped 5 cm onto a 0.3 m sphere: never inside radius + margin,
    and after 2 s the cloth rests on top of it. A free corner may keep a small flutter that
    alternates every step (collisions are resolved after the solve, which cannot know that
    its resting neighbours will be held up): a few mm per step at 2 steps per frame, up to
    about 2 cm at 1 step per frame."""
    radius, margin = 0.3, 0.01
    centre = np.array([0.2, -radius - margin - 0.05, 0.2])
    # without lift: the flutter's size is chaotic (a 1e-7 change of the air force moves its
    # late peak between 2 and 7 cm/s at 2 steps per frame), and cotton's lift, explicit in
    # this integrator, feeds the alternating mode
    cotton = replace(load_material("cotton", "test"), lift_coefficient=0.0)
    solver = make_solver(grid_fabric(10, size=0.4, plane="XZ"), cotton, frequency=24.0 * steps_per_frame,
                         colliders=sphere(centre, radius, margin, 0.5))
    closest = []

    def check(frame):
        x = solver.world_points().astype(np.float64)
        closest.append(np.linalg.norm(x - centre, axis=1).min())

    run(solver, 24.0, 48, each=check)
    assert min(closest) > radius + margin - 1e-4
    speed = np.linalg.norm(solver.world_velocities(solver._plan.h), axis=1)
    assert solver.frame_stats()["contacts"] > 50  # draped over the sphere
    assert np.median(speed) < 1e-3
    assert speed.max() < (0.05 if steps_per_frame == 2 else 0.6)
    np.testing.assert_allclose(solver.x[:, [0, 2]].mean(axis=0), centre[[0, 2]], atol=0.01)  # it stayed on top


def test_friction_stops_a_sliding_cloth_as_coulomb_says():
    """A cloth resting on the ground and pushed sideways at v0 slows by mu g h per step:
    it stops after v0 / (mu g) and slides h * sum(v0 - k mu g h)."""
    mu, g, v0, fps = 0.5, 9.81, 1.0, 24.0
    h = 1.0 / fps
    thickness = 0.002
    fabric = grid_fabric(5, size=0.2, plane="XZ", origin=(0.0, thickness, 0.0))
    material = replace(load_material("cotton", "test"), thickness=thickness)
    solver = make_solver(fabric, material, colliders=ground(0.0, mu), precision="float64")
    solver.v[:] = (v0, 0.0, 0.0)
    x_start = solver.x[:, 0].mean()
    run(solver, fps, 10)
    speeds = v0 - mu * g * h * np.arange(1, 11)
    expected = h * speeds[speeds > 0].sum()
    assert solver.x[:, 0].mean() - x_start == pytest.approx(expected, rel=1e-6)
    np.testing.assert_allclose(solver.x[:, 1], thickness, atol=1e-12)  # resting on the ground
    assert np.abs(solver.v).max() < 1e-9


def test_cloth_falls_onto_a_capsule_and_a_mesh_without_passing_through():
    cotton = load_material("cotton", "test")
    capsule = ColliderArrays(
        sphere_center=np.array([[-0.2, -0.3, 0.25], [0.7, -0.35, 0.25]], np.float32),
        sphere_radius=np.array([0.12, 0.06], np.float32), sphere_margin=np.zeros(2, np.float32),
        sphere_friction=np.zeros(2, np.float32), sphere_is_collider=np.zeros(2, bool),
        capsule_spheres=np.array([[0, 1]], np.int32), capsule_margin=np.array([0.005], np.float32),
        capsule_friction=np.array([0.5], np.float32),
    )
    # a box's top face, 2 triangles, under the other end of the cloth (a thin mesh)
    box = ColliderArrays(
        mesh_points=np.array([[-0.5, -0.5, -0.5], [1.5, -0.5, -0.5], [1.5, -0.5, 1.5], [-0.5, -0.5, 1.5]], np.float32),
        mesh_triangles=np.array([[0, 2, 1], [0, 3, 2]], np.int32), triangle_mesh=np.zeros(2, np.int32),
        mesh_margin=np.array([0.0], np.float32), mesh_friction=np.array([0.5], np.float32),
    )
    for colliders, inside in (
        (capsule, lambda x: _capsule_depth(x, capsule)),
        (box, lambda x: -(x[:, 1] + 0.5)),
    ):
        solver = make_solver(grid_fabric(10, size=0.5, plane="XZ"), cotton, colliders=lambda t, c=colliders: c)
        depths = []
        run(solver, 24.0, 36, each=lambda f: depths.append(inside(solver.world_points().astype(np.float64)).max()))
        assert max(depths) < 1e-4
        assert np.all(np.isfinite(solver.state.cur))


def _capsule_depth(x, arrays):
    """How far points are inside the capsule plus its margin (negative outside), by the
    swept-sphere formula sampled finely."""
    c0, c1 = arrays.sphere_center.astype(np.float64)
    r0, r1 = arrays.sphere_radius.astype(np.float64) + arrays.capsule_margin[0]
    t = np.linspace(0, 1, 2001)[:, None, None]
    centres = (1 - t) * c0 + t * c1
    radii = ((1 - t) * r0 + t * r1)[..., 0]
    return (radii - np.linalg.norm(x[None] - centres, axis=2)).max(axis=0)


def test_a_rising_sphere_lifts_the_cloth():
    """A sphere moving up at 0.5 m/s under a cloth lying on it carries the cloth along."""
    cotton = load_material("cotton", "test")
    radius = 0.3
    top = radius + 0.002  # the cloth's thickness

    def rising(time):
        return sphere((0.2, -top + 0.5 * time, 0.2), radius, 0.0, 0.5)(time)

    solver = make_solver(grid_fabric(8, size=0.4, plane="XZ", origin=(0.0, 0.0, 0.0)), cotton, colliders=rising)
    run(solver, 24.0, 24)
    centre = np.array([0.2, -top + 0.5, 0.2])
    x = solver.world_points().astype(np.float64)
    assert np.linalg.norm(x - centre, axis=1).min() > radius - 1e-4
    assert x[:, 1].max() > 0.45  # lifted by about 0.5 m
