"""ImplicitClothSolver against answers known without it: the discrete backward-Euler free
fall, a hanging strip's static stretch, energy decay, pins, stability where explicit Euler
explodes, drag's terminal velocity, unit invariance, motion constraints and the interface
the bake drives."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.errors import SceneError
from clothtool.integrators.implicit.solver import ImplicitClothSolver
from clothtool.profile import StageProfiler
from clothtool.settings import Material, MotionSettings, Placement, SolverConfig, load_material
from clothtool.solver.environment import Environment
from clothtool.solver.frame import Pose
from clothtool.solver.model import build_model
from tests.integrators.test_implicit_setup import fabric_from_mesh, grid_fabric, make_solver, replace, run
from tests.reference import implicit_energies as ref

TIGHT = {"cg_tolerance": 1e-12, "cg_max_iterations": 5000}


def test_free_fall_is_the_discrete_backward_euler_answer():
    """No pins, uniform motion: no strain, so each step is v += h g, x += h v exactly:
    x_n = x0 + n h v0 + h^2 g n (n + 1) / 2."""
    fps, frames = 24.0, 12
    h = 1.0 / fps
    g = np.array([0.0, -9.81, 0.0])
    v0 = np.array([0.3, 1.0, -0.2])
    fabric = grid_fabric(6, plane="XZ")
    still_air = replace(load_material("cotton", "test"), drag_coefficient=0.0, lift_coefficient=0.0)
    model = build_model("cloth", fabric, still_air, Placement(), 1.0, "Y")
    config = SolverConfig(frequency=fps, precision="float64", cg_tolerance=1e-13, cg_max_iterations=1000)
    solver = ImplicitClothSolver(model, config, Environment(g), StageProfiler(), initial_velocity=v0)
    x0 = solver.world_points().copy()
    run(solver, fps, frames)
    n = frames
    expected = x0 + n * h * v0 + h * h * g * n * (n + 1) / 2
    np.testing.assert_allclose(solver.world_points(), expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(solver.world_velocities(h), np.broadcast_to(v0 + n * h * g, x0.shape), atol=1e-5)


def test_hanging_strip_stretches_as_the_stretch_energy_says():
    """A two-column strip hangs from its top row. Each band between rows j and j+1 carries
    the weight W_j of the rows below; with E = Y a/2 (|w_v| - 1)^2 per triangle a band of
    width d stretches to |w_v| = 1 + W_j / (Y d), exactly, at any strain. Rows get equal
    masses so the strip stays symmetric."""
    rows, spacing, areal_density, modulus, g = 9, 0.05, 0.2, 2.0, 9.81
    pos = np.array([[c * spacing, -r * spacing, 0.0] for r in range(rows) for c in range(2)])
    quads = [(2 * r, 2 * r + 2, 2 * r + 3, 2 * r + 1) for r in range(rows - 1)]
    faces = np.array([(a, b, c) for a, b, c, d in quads] + [(a, c, d) for a, b, c, d in quads])
    fabric = fabric_from_mesh(pos, np.full(len(faces), 3), faces.reshape(-1), pinned=(0, 1))
    row_area = np.full(rows, spacing * spacing)
    row_area[[0, -1]] /= 2
    fabric = fabric.replace(particle_area=np.repeat(row_area / 2, 2).astype(np.float32),
                            particle_inv_mass=np.where(np.arange(2 * rows) < 2, 0.0, 2 / np.repeat(row_area, 2)).astype(np.float32))
    material = Material(areal_density=areal_density, stretch_modulus=modulus, shear_modulus=0.5, bend_modulus=0.0,
                        damping=0.5)
    solver = make_solver(fabric, material, frequency=24.0, precision="float64", strain_limit=0.0, **TIGHT)
    run(solver, 24.0, 240)
    weight_below = g * areal_density * np.cumsum(row_area[::-1])[::-1][1:]  # W_j for bands j = 0..rows-2
    expected_length = spacing * (1 + weight_below / (modulus * spacing)).sum()
    stretch = -solver.x[-1, 1] - (rows - 1) * spacing
    assert stretch == pytest.approx(expected_length - (rows - 1) * spacing, rel=0.01)
    assert weight_below[0] / (modulus * spacing) > 0.2  # a large strain: the law is exact, not linearised
    assert np.abs(solver.v).max() < 1e-6  # at rest


def total_energy(solver):
    rest, p = solver.rest, solver.params
    elastic = ref.triangle_energy(solver.x, rest.triangles, rest.tri_dinv, rest.tri_area, p.stretch, p.stretch, p.shear,
                                  p.compression)
    bend = ref.hinge_energy(solver.x, rest.hinges, rest.hinge_rest_angle, p.bend * rest.hinge_weight)
    kinetic = 0.5 * np.sum(solver.mass[:, None] * solver.v**2)
    potential = -np.sum(solver.mass[:, None] * solver.x * solver.gravity)
    return elastic + bend + kinetic + potential


def released_energies(gravity, compression):
    """Total energy after each step of a cloth released from a 20% stretch (two corners
    pinned), with damping."""
    material = Material(areal_density=0.2, stretch_modulus=50.0, shear_modulus=5.0, bend_modulus=1e-4, damping=0.5)
    solver = make_solver(grid_fabric(6, plane="XZ", pinned=(0, 5)), material, gravity=gravity, precision="float64",
                         strain_limit=0.0, compression_ratio=compression, **TIGHT)
    stretched = solver.world_points() * np.array([1.2, 1.0, 1.2])
    stretched[[0, 5]] = solver.world_points()[[0, 5]]
    solver.state.cur[:, :3] = stretched
    energies = [total_energy_at_rest_velocity(solver, stretched)]
    run(solver, 24.0, 48, each=lambda frame: energies.append(total_energy(solver)))
    return np.array(energies)


def total_energy_at_rest_velocity(solver, x):
    solver.x = x.copy()
    return total_energy(solver)


@pytest.mark.parametrize("gravity", [(0.0, 0.0, 0.0), (0.0, -9.81, 0.0)])
def test_energy_never_rises_with_damping(gravity):
    """Kinetic + gravitational + elastic energy never increases from step to step (Baraff &
    Witkin's energies: full compression stiffness, smooth)."""
    energies = released_energies(gravity, 1.0)
    assert np.diff(energies).max() <= 1e-12 * abs(energies[0])
    assert energies[-1] < energies[0] - 0.5 * abs(energies[0] - energies.min())


def test_energy_with_soft_compression_rises_at_most_slightly():
    """With compression softened (the default 0.1), the stiffness jumps where an edge passes
    its rest length and one linearised step can overshoot there: a step may gain a little
    energy, never more than 0.5% of the initial, and the cloth still settles."""
    energies = released_energies((0.0, 0.0, 0.0), 0.1)
    assert np.diff(energies).max() <= 5e-3 * energies[0]
    assert energies.max() <= energies[0] and energies[-1] < 0.05 * energies[0]


def test_pinned_particles_do_not_move_bit_for_bit():
    cotton = load_material("cotton", "test")
    solver = make_solver(grid_fabric(8, plane="XZ", pinned=(0, 7, 20)), cotton)
    before = solver.state.cur.copy()
    run(solver, 24.0, 24)
    pins = [0, 7, 20]
    np.testing.assert_array_equal(solver.state.cur[pins], before[pins])
    np.testing.assert_array_equal(solver.state.prev[pins], before[pins])
    assert np.abs(solver.state.cur[:, 1]).max() > 0.3  # the rest fell


def explicit_euler_blows_up(solver, frames, fps):
    """Symplectic Euler with the implicit solver's own forces (no Jacobian): v += h f/m,
    x += h v. Returns the frame at which a speed passes 1e3 m/s or goes NaN (None if never)."""
    h = 1.0 / fps
    solver.plan_frame(1, 0.0, h)
    free = solver.free != 0
    for frame in range(1, frames + 1):
        solver.compute_forces(h, 0.0)
        solver.v[free] += h * solver.force[free] / solver.mass[free, None]
        solver.x[free] += h * solver.v[free]
        speed = np.linalg.norm(solver.v, axis=1).max()
        if not np.isfinite(speed) or speed > 1e3:
            return frame
    return None


def test_stiff_cotton_is_stable_at_one_step_per_frame_where_explicit_euler_explodes():
    cotton = load_material("cotton", "test")
    fabric = grid_fabric(16, plane="XZ", pinned=(0, 15))
    solver = make_solver(fabric, cotton)
    speeds = []
    run(solver, 24.0, 48, each=lambda frame: speeds.append(np.linalg.norm(solver.world_velocities(1 / 24), axis=1).max()))
    assert np.all(np.isfinite(solver.state.cur))
    assert max(speeds) < 10.0
    assert solver.world_points()[:, 1].min() < -0.8  # it swung down
    assert explicit_euler_blows_up(make_solver(fabric, cotton), 48, 24.0) is not None


def test_strain_limit_bounds_the_release_transient():
    """Released flat from two pins, the first steps stretch edges next to the pins (no
    first-order resistance to sideways motion); the limit keeps them within 10%."""
    cotton = load_material("cotton", "test")
    fabric = grid_fabric(16, plane="XZ", pinned=(0, 15))
    rest = fabric.rest_pos.astype(np.float64)
    worst = {}
    for limit in (0.0, 0.1):
        solver = make_solver(fabric, cotton, strain_limit=limit)
        edges, lengths = solver.edges, solver.edge_rest_length

        def measure(frame, solver=solver, edges=edges, lengths=lengths, limit=limit):
            x = solver.world_points().astype(np.float64)
            strain = np.linalg.norm(x[edges[:, 1]] - x[edges[:, 0]], axis=1) / lengths - 1
            worst[limit] = max(worst.get(limit, 0.0), strain.max())

        run(solver, 24.0, 6, each=measure)
    assert worst[0.0] > 0.2 and worst[0.1] <= 0.1 + 1e-5
    assert rest.shape[0] == 256


def test_drag_gives_the_terminal_velocity():
    """A flat sheet falling face first: m g = 1/2 rho C_d A v^2 at v_t = sqrt(2 rho_a g / (rho C_d))."""
    material = replace(load_material("cotton", "test"), drag_coefficient=0.5)
    solver = make_solver(grid_fabric(5, plane="XZ"), material, precision="float64", **TIGHT)
    run(solver, 24.0, 96)
    terminal = np.sqrt(2 * material.areal_density * 9.81 / (solver.environment.fluid_density * 0.5))
    np.testing.assert_allclose(solver.v[:, 1], -terminal, rtol=1e-6)


def test_scene_units_do_not_change_the_motion():
    """The same cloth in a centimetre scene (positions x100, gravity in cm/s^2) moves the
    same, to rounding: stiffness, bending and thickness are converted consistently."""
    cotton = replace(load_material("cotton", "test"), bend_modulus=1e-3)
    fabric = grid_fabric(8, plane="XZ", pinned=(0, 7))
    solvers = []
    for units, g in ((1.0, -9.81), (0.01, -981.0)):
        model = build_model("cloth", fabric, cotton, Placement(), units, "Y")
        config = SolverConfig(frequency=24.0, precision="float64")
        solver = ImplicitClothSolver(model, config, Environment(np.array([0.0, g, 0.0])), StageProfiler())
        solver.params = replace(solver.params, cg_tolerance=1e-13, cg_max_iterations=5000)
        run(solver, 24.0, 12)
        solvers.append(solver)
    metres, centimetres = solvers
    np.testing.assert_allclose(centimetres.x / 100.0, metres.x, atol=1e-9)


def test_motion_constraints_hold_particles_within_their_radius():
    radius = np.full(36, np.inf, np.float32)
    radius[6:12] = 0.05  # the second row may move 5 cm
    radius[0:6] = 0.0  # the first row is held at rest
    fabric = grid_fabric(6, plane="XZ", max_distance=radius)
    solver = make_solver(fabric, load_material("cotton", "test"), motion=MotionSettings())
    rest = solver.world_points().copy()
    assert "motion" in solver.stage_names
    run(solver, 24.0, 24)
    x = solver.world_points()
    np.testing.assert_array_equal(x[:6], rest[:6])
    assert np.linalg.norm(x[6:12] - rest[6:12], axis=1).max() <= 0.05 + 1e-6
    assert x[30:, 1].min() < -0.2  # the free rows hang down


def test_interface_matches_the_position_based_solver():
    cotton = load_material("cotton", "test")
    solver = make_solver(grid_fabric(6, plane="XZ", pinned=(0, 5)), cotton, frequency=60.0)
    assert solver.stage_names == ["forces", "assemble", "cg-solve", "strain-limit", "integrate"]
    solver.warm_up()
    plan = solver.step(1, 0.0, 1 / 24)
    assert plan.iterations == 3 == solver.frame_stats()["steps"]  # round(60 / 24 = 2.5) as ClothSolver
    solver = make_solver(grid_fabric(6, plane="XZ", pinned=(0, 5)), cotton, frequency=48.0)
    plan = solver.step(1, 0.0, 1 / 24)
    assert plan.iterations == 2 == solver.frame_stats()["steps"]
    assert plan.h == pytest.approx(1 / 48)
    stats = solver.frame_stats()
    assert stats["cg_iterations"] > 0 and 0 <= stats["cg_max_residual"] <= 1e-6
    assert set(solver.last_cg) == {"iterations", "residual"}
    state = solver.state
    assert state.cur.dtype == np.float32 and state.cur.shape == (36, 4)
    np.testing.assert_array_equal(state.cur[:, 3], solver.model.inv_mass)
    np.testing.assert_allclose(solver.world_velocities(plan.h), solver.v, atol=2e-4)
    assert set(solver.profiler.seconds) >= set(solver.stage_names)
    solver.iterate(solver.iteration(solver.plan_frame(2, 1 / 24, 1 / 24), 0))  # the bake's way
    assert not solver.asleep


def test_a_track_is_refused_with_a_clear_error():
    fabric = grid_fabric(4)
    model = build_model("cape", fabric, load_material("cotton", "test"), Placement(), 1.0, "Y")
    with pytest.raises(SceneError, match="cape.*world space only"):
        ImplicitClothSolver(model, SolverConfig(), Environment(np.zeros(3)), StageProfiler(),
                            track=lambda time: Pose.identity())


def test_state_changed_from_outside_is_adopted():
    """Positions (and velocities through prev) written into the state between frames are
    what the next step starts from, as with the position-based solver."""
    cotton = load_material("cotton", "test")
    solver = make_solver(grid_fabric(4, plane="XZ"), cotton, gravity=(0.0, 0.0, 0.0), precision="float64")
    run(solver, 24.0, 1)
    solver.state.cur[:, 0] += 1.0
    solver.state.prev[:, 0] += 1.0 - 0.5 / 24  # velocity +0.5 m/s along x
    solver.step(2, 1 / 24, 1 / 24)
    np.testing.assert_allclose(solver.v[:, 0], 0.5, atol=1e-9)
    np.testing.assert_allclose(solver.x[:, 0], grid_fabric(4, plane="XZ").rest_pos[:, 0] + 1.0 + 0.5 / 24, atol=1e-9)
