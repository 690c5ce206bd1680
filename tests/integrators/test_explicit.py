"""ExplicitClothSolver (mass-spring, symplectic Euler) against answers known without its code:
the discrete free fall, a spring's frequency, a hanging chain's static stretch, the
stability limit, the wind's area law, contact with friction, and the ClothSolver interface.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from clothtool.collision.colliders import ColliderArrays
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.errors import SceneError, UnstableError
from clothtool.integrators.explicit import ExplicitClothSolver, stability_limit
from clothtool.integrators.explicit.stability import stability_report
from clothtool.mesh.shapes import grid
from clothtool.profile import StageProfiler
from clothtool.settings import Material, Placement, SolverConfig
from clothtool.solver.environment import Environment
from clothtool.solver.frame import Pose
from clothtool.solver.measure import ClothMeter
from clothtool.solver.model import build_model
from tests.physics.conftest import fabric_from_arrays

G = np.array([0.0, -9.81, 0.0])
EPS32 = float(np.finfo(np.float32).eps)


@dataclasses.dataclass(frozen=True)
class ForcedConfig(SolverConfig):
    """SolverConfig with the `force` flag the bake's --force sets (skips the stability check)."""

    force: bool = True


def make_solver(fabric, material, config=SolverConfig(), gravity=G, wind=None, density=1.0, colliders=None, **kwargs):
    model = build_model("cloth", fabric, material, Placement(), 1.0, "Y")
    environment = Environment(np.asarray(gravity, np.float64), wind, density, colliders)
    return ExplicitClothSolver(model, config, environment, StageProfiler(), **kwargs)


def chain(n=10, spacing=0.1, mass=0.1, k=1000.0, damping=1.0):
    """n free masses hanging below a pinned particle, one spring k between neighbours."""
    pos = np.zeros((n + 1, 3))
    pos[:, 1] = -spacing * np.arange(n + 1)
    inv_mass = np.full(n + 1, 1.0 / mass)
    inv_mass[0] = 0.0
    pairs = np.stack([np.arange(n), np.arange(1, n + 1)], axis=1)
    fabric = fabric_from_arrays(pos, inv_mass, [pairs[0::2], pairs[1::2]], area=mass)
    # k = stretch_modulus * A / L^2 with A = mass (areal density 1)
    material = Material(areal_density=1.0, stretch_modulus=k * spacing**2 / mass, damping=damping, drag_coefficient=0.0)
    return fabric, material


def sheet(n=8, spacing=0.05, pins=(0, -1), plane="XY", origin=(0.0, 0.0, 0.0)):
    mesh = grid(n, n, spacing, plane=plane, origin=origin)
    pinned = [p if p >= 0 else n + p for p in pins]  # -1: the top row's last particle
    fabric = cook_fabric(mesh, CookOptions(tethers="none", pin_file=None)).fabric
    inv_mass = fabric.particle_inv_mass.copy()
    inv_mass[pinned] = 0.0
    return fabric.replace(particle_inv_mass=inv_mass)


SOFT = Material(areal_density=0.15, stretch_modulus=50.0, shear_modulus=5.0, bend_modulus=1e-7, damping=0.3,
                drag_coefficient=0.0, thickness=0.002, friction=0.5)


def drive(solver, fps, frames, each_substep=None):
    """Drive like the bake: plan each frame, then its iterations one by one."""
    dt = 1.0 / fps
    for frame in range(1, frames + 1):
        plan = solver.plan_frame(frame, (frame - 1) * dt, dt)
        for index in range(plan.iterations):
            solver.iterate(solver.iteration(plan, index))
            if each_substep is not None:
                each_substep(plan.h)
    return frames * dt


# ------------------------------------------------------------------------------ free fall
@pytest.mark.parametrize("precision", ["float64", "float32"])
def test_free_fall_is_the_exact_discrete_answer(precision):
    """v_k = v_0 + k h g and x_n = x_0 + h sum_{k=1..n} v_k = x_0 + n h v_0 + h^2 g n (n+1) / 2."""
    fabric = fabric_from_arrays([[0, 0, 0], [1, 2, 3], [0.5, 1, 0]], [1.0, 0.5, 0.0], area=[1.0, 2.0, 1.0])
    v0 = np.array([1.0, 2.0, 0.5])
    solver = make_solver(fabric, Material(areal_density=1.0), SolverConfig(frequency=600.0, precision=precision),
                         initial_velocity=v0)
    start = solver.state.cur.copy()
    drive(solver, 60.0, 30)
    n, h = 300, 1.0 / 600.0
    x = start[:2, :3].astype(np.float64) + n * h * v0 + h * h * G * n * (n + 1) / 2
    v = v0 + n * h * G
    cur = solver.state.cur.astype(np.float64)
    if precision == "float64":
        np.testing.assert_allclose(cur[:2, :3], x, rtol=0, atol=1e-12)
        np.testing.assert_allclose(solver.velocity[:2], np.tile(v, (2, 1)), rtol=0, atol=1e-12)
    else:  # n additions of values below ~12, each rounded by at most U * 12 (and v's own drift)
        np.testing.assert_allclose(cur[:2, :3], x, rtol=0, atol=n * EPS32 * 12)
        np.testing.assert_allclose(solver.velocity[:2], np.tile(v, (2, 1)), rtol=0, atol=n * EPS32 * 5)
    np.testing.assert_array_equal(solver.state.cur[2], start[2])  # the pinned particle
    # the writers' velocity (cur - prev) / h is the integrator's velocity
    np.testing.assert_allclose((cur[:2, :3] - solver.state.prev[:2, :3]) / h, np.tile(v, (2, 1)), atol=1e-3)


# ------------------------------------------------------------------------------ spring
def test_spring_oscillates_at_sqrt_k_over_m():
    """A 1 kg particle on a 400 N/m spring to a pinned one, undamped, no gravity, kicked at
    0.1 m/s along the spring: x(t) = (v0 / omega) sin(omega t), f = sqrt(k/m) / 2 pi."""
    k, m, v0 = 400.0, 1.0, 0.1
    fabric = fabric_from_arrays([[0, 0, 0], [1, 0, 0]], [0.0, 1.0], [[[0, 1]]], area=1.0)
    material = Material(areal_density=1.0, stretch_modulus=k, damping=0.0, drag_coefficient=0.0)
    solver = make_solver(fabric, material, SolverConfig(frequency=400.0), gravity=(0, 0, 0),
                         initial_velocity=(v0, 0, 0))
    times, x = [0.0], [0.0]

    def record(h):
        times.append(times[-1] + h)
        x.append(float(solver.state.cur[1, 0]) - 1.0)

    drive(solver, 40.0, 80, record)  # 2 s, h = 1/400 s, h omega = 0.05
    t, x = np.array(times), np.array(x)
    up = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
    crossings = t[up] - x[up] * (t[up + 1] - t[up]) / (x[up + 1] - x[up])
    period = np.diff(crossings).mean()
    frequency = 1.0 / period
    omega = math.sqrt(k / m)
    assert len(crossings) >= 5
    assert frequency == pytest.approx(omega / (2 * math.pi), rel=0.01)
    # and the discrete (symplectic Euler) frequency: cos(omega_d h) = 1 - (omega h)^2 / 2
    omega_d = math.acos(1 - (omega / 400.0) ** 2 / 2) * 400.0
    assert frequency == pytest.approx(omega_d / (2 * math.pi), rel=1e-3)
    assert np.abs(x).max() == pytest.approx(v0 / omega, rel=0.03)  # no energy drift


# ------------------------------------------------------------------------------ chain
def test_hanging_chain_static_stretch():
    """N masses m on springs k below a pin: spring j carries (N - j + 1) m g, so the chain
    stretches m g N (N+1) / (2k) in all. Damped to rest (zeta = 1) over 10 s."""
    n, spacing, m, k = 10, 0.1, 0.1, 1000.0
    fabric, material = chain(n, spacing, m, k, damping=1.0)
    solver = make_solver(fabric, material, SolverConfig(frequency=600.0))
    drive(solver, 60.0, 600)
    y = solver.state.cur[:, 1].astype(np.float64)
    stretch = (y[0] - y[-1]) - n * spacing
    assert stretch == pytest.approx(m * 9.81 * n * (n + 1) / (2 * k), rel=1e-3)
    extensions = -np.diff(y) - spacing
    np.testing.assert_allclose(extensions, m * 9.81 * np.arange(n, 0, -1) / k, rtol=2e-3)
    assert np.abs(solver.velocity).max() < 1e-4


def test_units_a_centimetre_scene_sags_the_same_in_metres():
    """The same chain in a scene of centimetres (gravity 981 units/s^2): spring constants
    and dampers are the same numbers in any length unit, so the stretch is the same in metres."""
    n, spacing, m, k = 10, 0.1, 0.1, 1000.0
    fabric, material = chain(n, spacing, m, k, damping=1.0)
    model = build_model("cloth", fabric, material, Placement(), 0.01, "Y")
    environment = Environment(np.array([0.0, -981.0, 0.0]))
    solver = ExplicitClothSolver(model, SolverConfig(frequency=600.0), environment, StageProfiler())
    in_metres = build_model("c", fabric, material, Placement(), 1.0, "Y")
    assert stability_limit(model) == pytest.approx(stability_limit(in_metres))
    drive(solver, 60.0, 600)
    y = solver.state.cur[:, 1].astype(np.float64) * 0.01  # metres
    assert (y[0] - y[-1]) - n * spacing == pytest.approx(m * 9.81 * n * (n + 1) / (2 * k), rel=1e-3)


# ------------------------------------------------------------------------------ pinned
def test_pinned_particles_stay_bit_for_bit():
    fabric = sheet(8, 0.05, pins=(0, 7), plane="XZ")
    sphere = ColliderArrays(
        sphere_center=np.array([[0.17, -0.2, 0.17]], np.float32), sphere_radius=np.array([0.15], np.float32),
        sphere_margin=np.zeros(1, np.float32), sphere_friction=np.full(1, 0.5, np.float32),
        sphere_is_collider=np.array([True]),
    )
    material = dataclasses.replace(SOFT, drag_coefficient=0.5)
    solver = make_solver(fabric, material, SolverConfig(frequency=1200.0), wind=lambda t: np.array([1.0, 0.0, 3.0]),
                         colliders=lambda t: sphere)
    assert solver.stage_names == ["forces", "wind", "integrate", "collide"]
    pinned = solver.model.inv_mass == 0
    start = solver.state.cur.copy()
    drive(solver, 60.0, 20)
    assert np.abs(solver.state.cur[~pinned] - start[~pinned]).max() > 0.05  # the rest moved
    assert solver.state.cur[pinned].tobytes() == start[pinned].tobytes()
    assert solver.state.prev[pinned].tobytes() == start[pinned].tobytes()
    assert not solver.velocity[pinned].any()


# ------------------------------------------------------------------------------ stability
def max_speed_over(solver, seconds):
    """Simulate one substep per frame for ``seconds``; the largest speed seen (inf on NaN)."""
    h = 1.0 / solver.config.frequency
    fastest = 0.0
    for frame in range(1, int(round(seconds / h)) + 1):
        solver.step(frame, (frame - 1) * h, h)
        speed = float(np.sqrt((solver.velocity.astype(np.float64) ** 2).sum(axis=1)).max())
        if not math.isfinite(speed):
            return math.inf
        fastest = max(fastest, speed)
        if fastest > 100.0:
            break
    return fastest


def stability_cases():
    fabric, material = chain(10, 0.1, 0.1, 1000.0, damping=0.0)
    yield "chain", fabric, material
    fabric, material = chain(10, 0.1, 0.1, 1000.0, damping=0.5)
    yield "damped chain", fabric, material
    yield "sheet", sheet(8, 0.05), SOFT


@pytest.mark.parametrize("name, fabric, material", list(stability_cases()), ids=lambda v: v if isinstance(v, str) else "")
def test_just_below_the_limit_stays_bounded(name, fabric, material):
    model = build_model("cloth", fabric, material, Placement(), 1.0, "Y")
    h = 0.97 * stability_limit(model)
    solver = make_solver(fabric, material, SolverConfig(frequency=1.0 / h))
    assert max_speed_over(solver, 2.0) < 10.0


@pytest.mark.parametrize("factor", [1.5, 2.0, 3.0])
@pytest.mark.parametrize("name, fabric, material", list(stability_cases()), ids=lambda v: v if isinstance(v, str) else "")
def test_beyond_the_limit_blows_up_when_forced(name, fabric, material, factor):
    model = build_model("cloth", fabric, material, Placement(), 1.0, "Y")
    h = factor * stability_limit(model)
    solver = make_solver(fabric, material, ForcedConfig(frequency=1.0 / h))
    assert max_speed_over(solver, 2.0) > 100.0


def test_limit_of_one_spring_is_two_over_omega_lowered_by_damping():
    """One spring to a pinned end: h_max = (2 / omega) (sqrt(1 + zeta^2) - zeta)."""
    for zeta in (0.0, 0.3, 1.0):
        fabric = fabric_from_arrays([[0, 0, 0], [1, 0, 0]], [0.0, 0.5], [[[0, 1]]], area=2.0)
        material = Material(areal_density=1.0, stretch_modulus=800.0, damping=zeta)
        model = build_model("c", fabric, material, Placement(), 1.0, "Y")
        omega = math.sqrt(1600.0 / 2.0)  # k = E A / L^2 = 800 * 2 / 1 N/m, m = 2 kg
        assert stability_limit(model) == pytest.approx(2 / omega * (math.sqrt(1 + zeta**2) - zeta), rel=1e-12)


def test_too_long_a_substep_is_refused_with_the_figure():
    fabric, material = chain(10, 0.1, 0.1, 1000.0, damping=0.5)
    model = build_model("cloth", fabric, material, Placement(), 1.0, "Y")
    report = stability_report(model)
    h_max = report["h_max_s"]
    config = SolverConfig(frequency=0.5 / h_max)
    solver = make_solver(fabric, material, config)
    assert solver.stability["h_max_s"] == pytest.approx(h_max)
    with pytest.raises(UnstableError) as caught:
        solver.plan_frame(1, 0.0, 1.0 / 60.0)
    message = str(caught.value)
    needed = math.ceil((1.0 / 60.0) / h_max) * 60.0
    assert f"h <= {h_max:.3g} s" in message and f"{needed:.6g} Hz" in message and "--force" in message
    assert "cloth 'cloth'" in message
    # the frequency the message asks for is accepted, and so is --force
    make_solver(fabric, material, SolverConfig(frequency=needed)).plan_frame(1, 0.0, 1.0 / 60.0)
    make_solver(fabric, material, ForcedConfig(frequency=0.5 / h_max)).plan_frame(1, 0.0, 1.0 / 60.0)
    with pytest.raises(UnstableError, match=f"{h_max:.3g}"):  # early, when the frame length is known
        make_solver(fabric, material, config, frame_dt=1.0 / 60.0)


# ------------------------------------------------------------------------------ wind
def flat_sheet(side):
    """Two triangles making a side x side square in the XY plane (normal +Z), all free."""
    pos = np.array([[0, 0, 0], [side, 0, 0], [side, side, 0], [0, side, 0]], np.float64)
    return fabric_from_arrays(pos, [1.0] * 4, triangles=[[0, 1, 2], [0, 2, 3]], area=1.0)


def wind_force(fabric, wind, density=1.2, drag=0.5, lift=0.0):
    material = Material(areal_density=1.0, drag_coefficient=drag, lift_coefficient=lift)
    solver = make_solver(fabric, material, SolverConfig(frequency=600.0), gravity=(0, 0, 0),
                         wind=lambda t: np.asarray(wind, np.float64), density=density)
    assert "wind" in solver.stage_names
    solver.step(1, 0.0, 1.0 / 600.0)
    total = solver.force.astype(np.float64).sum(axis=0)
    # the integrator applied it: sum m dv / h
    impulse = (solver.model.mass[:, None] * solver.velocity).sum(axis=0) * 600.0
    np.testing.assert_allclose(impulse, total, rtol=1e-5, atol=1e-9)
    return total


def test_wind_drag_is_quadratic_and_in_proportion_to_area():
    """A still sheet in wind w: F = 1/2 rho C_d A |n.w| w, the textbook drag."""
    wind = np.array([1.0, 0.0, 2.0])
    small = wind_force(flat_sheet(0.5), wind)
    large = wind_force(flat_sheet(0.5 * math.sqrt(2.0)), wind)
    np.testing.assert_allclose(small, 0.5 * 1.2 * 0.5 * 0.25 * 2.0 * wind, rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(large, 2.0 * small, rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(wind_force(flat_sheet(0.5), 3.0 * wind), 9.0 * small, rtol=1e-5, atol=1e-9)
    assert not wind_force(flat_sheet(0.5), [3.0, -1.0, 0.0]).any()  # wind in the sheet's plane


def test_wind_on_a_tilted_sheet_gives_drag_along_the_wind_and_lift_across_it():
    """Drag 1/2 rho C_d A |w|^2 |cos| along w; lift 1/2 rho C_l A |w|^2 cos sin at right angles
    to w, towards the normal's part across the wind (theta: between the normal and w)."""
    angle = 0.6
    rotation = np.array([[1, 0, 0], [0, math.cos(angle), -math.sin(angle)], [0, math.sin(angle), math.cos(angle)]])
    fabric = flat_sheet(0.5)
    fabric = fabric.replace(rest_pos=(fabric.rest_pos.astype(np.float64) @ rotation.T).astype(np.float32))
    normal = rotation @ [0.0, 0.0, 1.0]
    wind = np.array([0.5, 1.0, 3.0])
    speed = np.linalg.norm(wind)
    cos = normal @ wind / speed
    across = normal - cos * wind / speed  # length sin
    q = 0.5 * 1.2 * 0.25 * speed**2
    drag = wind_force(fabric, wind, drag=0.5)
    np.testing.assert_allclose(drag, q * 0.5 * abs(cos) * wind / speed, rtol=1e-5, atol=1e-7)
    lift = wind_force(fabric, wind, drag=0.0, lift=0.3)
    np.testing.assert_allclose(lift, q * 0.3 * cos * across, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(np.linalg.norm(across), math.sqrt(1 - cos * cos), rtol=1e-12)


# ------------------------------------------------------------------------------ contact
def ground(friction=0.4, margin=0.0, height=0.0):
    return ColliderArrays(
        plane=np.array([[0.0, 1.0, 0.0, height]], np.float32), convex_plane_offsets=np.array([0, 1], np.int32),
        convex_margin=np.array([margin], np.float32), convex_friction=np.array([friction], np.float32),
    )


def test_sliding_on_the_ground_decelerates_at_mu_g():
    """A lone particle sliding at 2 m/s on the ground, mu = sqrt(0.4 * 0.4): each substep
    gravity pushes it in by g h, the contact removes that and friction mu g h of the slide."""
    fabric = fabric_from_arrays([[0, 0.002, 0]], [1.0], area=1.0)
    material = Material(areal_density=1.0, thickness=0.002, friction=0.4)
    collider = ground(0.4)
    solver = make_solver(fabric, material, SolverConfig(frequency=600.0), colliders=lambda t: collider,
                         initial_velocity=(2.0, 0.0, 0.0))
    drive(solver, 60.0, 12)  # 0.2 s
    assert float(solver.velocity[0, 0]) == pytest.approx(2.0 - 0.4 * 9.81 * 0.2, rel=1e-4)
    assert float(solver.state.cur[0, 1]) == pytest.approx(0.002, abs=1e-7)
    drive(solver, 60.0, 60)  # it stops after 2 / (0.4 g) = 0.51 s and stays
    assert float(solver.velocity[0, 0]) == 0.0


def cube_mesh(center, half):
    corners = np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], np.float64) * half + center
    quads = [[0, 2, 6, 4], [1, 3, 7, 5], [0, 1, 5, 4], [2, 3, 7, 6], [0, 1, 3, 2], [4, 5, 7, 6]]
    triangles = []
    for a, b, c, d in quads:
        for tri in ([a, b, c], [a, c, d]):
            p = corners[tri]
            if np.cross(p[1] - p[0], p[2] - p[0]) @ (p.mean(axis=0) - center) < 0:
                tri = [tri[0], tri[2], tri[1]]
            triangles.append(tri)
    return corners.astype(np.float32), np.array(triangles, np.int32)


def colliders_of(kind):
    """(ColliderArrays, signed distance to the grown surface) of one collider under a sheet."""
    f32 = lambda x: np.asarray(x, np.float32)  # noqa: E731
    if kind == "sphere":
        c = np.array([0.17, -0.2, 0.17])
        arrays = ColliderArrays(sphere_center=f32([c]), sphere_radius=f32([0.12]), sphere_margin=f32([0.01]),
                                sphere_friction=f32([0.5]), sphere_is_collider=np.array([True]))
        return arrays, lambda x: np.linalg.norm(x - c, axis=1) - 0.13
    if kind == "capsule":
        c0, c1, r0, r1 = np.array([-0.1, -0.2, 0.17]), np.array([0.45, -0.2, 0.17]), 0.12, 0.06
        arrays = ColliderArrays(sphere_center=f32([c0, c1]), sphere_radius=f32([r0, r1]), sphere_margin=f32([0.01, 0.01]),
                                sphere_friction=f32([0.5, 0.5]), sphere_is_collider=np.array([False, False]),
                                capsule_spheres=np.array([[0, 1]], np.int32), capsule_margin=f32([0.01]),
                                capsule_friction=f32([0.5]))

        def distance(x):
            t = np.linspace(0.0, 1.0, 2001)
            centres = c0 + t[:, None] * (c1 - c0)
            return (np.linalg.norm(x[:, None, :] - centres[None], axis=2) - (r0 + t * (r1 - r0))).min(axis=1) - 0.01

        return arrays, distance
    if kind == "box":
        lo, hi = np.array([0.05, -0.4, 0.05]), np.array([0.3, -0.1, 0.3])
        planes = [[1, 0, 0, hi[0]], [-1, 0, 0, -lo[0]], [0, 1, 0, hi[1]],
                  [0, -1, 0, -lo[1]], [0, 0, 1, hi[2]], [0, 0, -1, -lo[2]]]
        arrays = ColliderArrays(plane=f32(planes), convex_plane_offsets=np.array([0, 6], np.int32),
                                convex_margin=f32([0.01]), convex_friction=f32([0.5]))
        return arrays, lambda x: np.max([np.asarray(p[:3]) @ x.T - p[3] for p in planes], axis=0) - 0.01
    center, half = np.array([0.17, -0.25, 0.17]), 0.12
    points, triangles = cube_mesh(center, half)
    arrays = ColliderArrays(mesh_points=points, mesh_triangles=triangles, triangle_mesh=np.zeros(12, np.int32),
                            mesh_margin=f32([0.01]), mesh_friction=f32([0.5]))
    return arrays, lambda x: np.abs(x - center).max(axis=1) - half - 0.01  # inside the cube's (mesh) boundary


@pytest.mark.parametrize("kind", ["sphere", "capsule", "box", "mesh"])
def test_a_falling_sheet_rests_outside_each_collider(kind):
    arrays, distance = colliders_of(kind)
    fabric = sheet(8, 0.05, pins=(), plane="XZ")
    solver = make_solver(fabric, SOFT, SolverConfig(frequency=1200.0), colliders=lambda t: arrays)
    drive(solver, 60.0, 30)
    d = distance(solver.state.cur[:, :3].astype(np.float64))
    assert d.min() > -2e-3  # outside the grown surface (the mesh's cube: to its margin)
    assert (d < 5e-3).sum() >= 3  # and touching it
    assert np.isfinite(solver.state.cur).all()


def test_moving_colliders_are_interpolated_and_carry_the_cloth():
    """A ground plane rising at 1 m/s lifts a particle resting on it (inelastic contact)."""
    fabric = fabric_from_arrays([[0, 0.002, 0]], [1.0], area=1.0)
    solver = make_solver(fabric, Material(areal_density=1.0, thickness=0.002), SolverConfig(frequency=600.0),
                         colliders=lambda t: ground(0.5, height=1.0 * t))
    drive(solver, 60.0, 30)
    assert float(solver.state.cur[0, 1]) == pytest.approx(0.5 + 0.002, abs=1e-4)
    assert float(solver.velocity[0, 1]) == pytest.approx(1.0, abs=0.02)


# ------------------------------------------------------------------------------ interface
def test_parallel_spring_sets_give_the_serial_bits():
    fabric = sheet(6, 0.05)
    serial = make_solver(fabric, SOFT, SolverConfig(frequency=1200.0))
    parallel = make_solver(fabric, SOFT, SolverConfig(frequency=1200.0, parallel_threshold=1))
    assert parallel.parallel and not serial.parallel
    drive(serial, 60.0, 3)
    drive(parallel, 60.0, 3)
    assert serial.state.cur.tobytes() == parallel.state.cur.tobytes()


def test_tracked_cloth_is_refused():
    with pytest.raises(SceneError, match="world space"):
        make_solver(flat_sheet(1.0), Material(), track=lambda t: Pose.identity())


def test_bake_style_driving_matches_step_and_the_meters_read_the_velocity():
    fabric = sheet(6, 0.05)
    a = make_solver(fabric, SOFT, SolverConfig(frequency=1200.0))
    b = make_solver(fabric, SOFT, SolverConfig(frequency=1200.0))
    a.warm_up()
    for frame in range(1, 6):
        plan = a.step(frame, (frame - 1) / 60.0, 1.0 / 60.0)
    drive(b, 60.0, 5)
    assert a.state.cur.tobytes() == b.state.cur.tobytes()
    assert plan.iterations == 20 and plan.h == pytest.approx(1.0 / 1200.0)
    stats = ClothMeter(a).measure(plan.h, percentiles=False)
    speed = np.linalg.norm(a.world_velocities(plan.h), axis=1)
    assert stats["max_speed"] == pytest.approx(float(speed.max()), rel=1e-3)
    assert stats["finite"] and set(stats["strain"]) == {"vertical", "horizontal", "shearing", "bending"}
    assert a.world_points().shape == (36, 3) and not a.asleep
    assert set(a.profiler.seconds) == {"forces", "integrate"}
