"""One table of physical cases x every registered integrator, each a convergence test.

Rows are the cases below, columns every integrator of clothtool.sim.integrators.REGISTRY in
the presets of tests/physics/behaviour_setup.py (the position-based one as ``production``
and ``physical``). A case that needs a capability an integrator does not declare is skipped
with the reason, computed from the declared capabilities. Each case measures a relative error
against a closed form or a small float64 numpy solution at a ladder of solver frequencies
(doubling), and asserts that

* the error falls by at least CONVERGENCE (0.65) per doubling until it is below the case's
  stated floor (where rounding, the time a scene is given to settle, or a stiff stand-in for a
  rigid body, limit what the frequency can improve), and
* the error at the finest rung is below the case's bound.

Expected answers per column (``Column.elastic``): ``production`` promises an inextensible
cloth, so its static stretch converges to zero (f^-2) and its catenaries to the inextensible
one whatever the moduli; ``physical``, ``implicit`` and ``explicit`` promise the material's
linear elasticity (a band of width w stretched by T strains by T / (Y w)).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable

import numpy as np
import pytest
from scipy.special import ellipk

from clothtool.settings import Material, PhaseSettings
from tests.physics.behaviour_setup import (
    FPS,
    Column,
    G,
    add_velocity,
    columns,
    cooked_sheet,
    crossing_times,
    elastic_catenary,
    explicit_frequencies,
    half_space,
    iteration_length,
    make_solver,
    masses,
    positions,
    ribbon,
    rotated_about_x,
    run,
    single_particle,
    skip_reason,
    start_at,
    velocities,
)

CONVERGENCE = 0.65  # error(2 f) <= CONVERGENCE error(f) while error(f) is above the floor


@dataclasses.dataclass(frozen=True)
class Case:
    """One row: ``measure(column, frequency) -> relative error``, run at ``ladder`` (doubled
    for the explicit integrator until stable); errors below ``floor`` count as converged;
    the finest rung's error must be below ``bound``."""

    name: str
    measure: Callable[[Column, float], float]
    ladder: tuple[float, ...]
    floor: float
    bound: float
    requires: frozenset[str] = frozenset()
    scene: Callable[[Column], tuple] | None = None  # (fabric, material) for the explicit ladder


# ---------------------------------------------------------------------------------- free fall
FALL_SECONDS = 0.5


def free_fall(column: Column, frequency: float) -> float:
    """One particle falls from rest for 0.5 s: y = y0 - g t^2 / 2 (relative to the drop)."""
    y0 = 2.0
    solver = make_solver(column, single_particle([0.0, y0, 0.0]), Material(areal_density=1.0, damping=0.0), frequency)
    run(solver, FALL_SECONDS)
    drop = 0.5 * G * FALL_SECONDS**2
    return abs(positions(solver)[0, 1] - (y0 - drop)) / drop


# ---------------------------------------------------------------------------------- drag
RHO = 1.2
AIR = Material(areal_density=0.15, drag_coefficient=0.8, lift_coefficient=0.0, damping=0.0, stretch_modulus=10.0,
               shear_modulus=1.0, bend_modulus=1e-6, bending=PhaseSettings(stiffness=0.2))


def air_sheet(column: Column):
    return cooked_sheet(4, 4, 0.1, plane="XZ"), AIR


def terminal_speed(column: Column, frequency: float) -> float:
    """A 4 x 4 sheet falls face-on for 1.25 s (seven time constants v_t / g): its mean
    velocity against 1/2 rho C_d A v^2 = m g, v_t = sqrt(2 sigma g / (rho C_d))."""
    fabric, material = air_sheet(column)
    solver = make_solver(column, fabric, material, frequency, fluid_density=RHO, strain_limit=0.0)
    run(solver, 1.25)
    v_t = math.sqrt(2 * material.areal_density * G / (RHO * material.drag_coefficient))
    mass = solver.model.mass
    velocity = mass @ velocities(solver, iteration_length(frequency)) / mass.sum()
    return abs(-velocity[1] / v_t - 1.0) + abs(velocity[[0, 2]]).max() / v_t


# ---------------------------------------------------------------------------------- pendulum
THETA0 = math.radians(8.0)
PLATE = Material(areal_density=1.0, damping=0.0, stretch_modulus=1e5, shear_modulus=1e4, bend_modulus=0.0)


def plate(column: Column):
    """One 10 cm quad hanging from its pinned top edge, turned THETA0 about that edge (the X
    axis): its two free corners are held by the pins and each other, a rigid plate."""
    fabric = cooked_sheet(2, 2, 0.1, plane="XY", bending=False)
    inv_mass = fabric.particle_inv_mass.copy()
    inv_mass[:2] = 0.0
    return rotated_about_x(fabric.replace(particle_inv_mass=inv_mass), THETA0), PLATE


def pendulum_period(column: Column, frequency: float) -> float:
    """The plate swings as a rigid compound pendulum of point masses m_i at distances r_i
    below the hinge: T = 4 sqrt(I / (g sum m r)) K(sin^2(theta0 / 2)), I = sum m r^2
    (stiff: its static stretch, ~1e-5, moves the period by ~5e-6). Mean of the first two
    periods from the bottom row's crossings of the vertical."""
    fabric, material = plate(column)
    solver = make_solver(column, fabric, material, frequency, strain_limit=0.0)
    mass = solver.model.mass
    free = solver.model.inv_mass > 0
    r = np.linalg.norm(positions(solver)[:, 1:], axis=1)
    inertia, moment = float(mass[free] @ r[free] ** 2), float(mass[free] @ r[free])
    exact = 4.0 * math.sqrt(inertia / (G * moment)) * float(ellipk(math.sin(THETA0 / 2) ** 2))
    times, z = [], []
    bottom = solver.model.inv_mass > 0
    run(solver, 2.4 * exact, each=lambda t: (times.append(t), z.append(positions(solver)[bottom, 2].mean())))
    crossings = crossing_times(times, z)
    assert crossings.size >= 5, f"{column.name} at {frequency} Hz: the plate crossed the vertical {crossings.size} times"
    return abs((crossings[4] - crossings[0]) / 2.0 / exact - 1.0)


# ---------------------------------------------------------------------------------- catenaries
LINK, WIDTH, MASSES, SPAN = 0.1, 0.05, 8, 0.75
CHAIN_DENSITY = 1.0  # kg/m^2: a row weighs sigma LINK WIDTH g


def chain(modulus: float):
    def scene(column: Column):
        """A ribbon of MASSES free rows between two pinned rows SPAN apart, at rest in the
        inextensible catenary (its rest shape), of stretch modulus ``modulus``."""
        start = elastic_catenary(MASSES, LINK, SPAN, 1.0, math.inf)
        material = Material(areal_density=CHAIN_DENSITY, stretch_modulus=modulus, shear_modulus=modulus / 1000,
                            bend_modulus=0.0, damping=column.settling()[0], drag_coefficient=0.0)
        return ribbon(start, WIDTH, pinned_rows=(0, -1), shearing=False), material

    return scene


def catenary_sag(modulus: float):
    def measure(column: Column, frequency: float) -> float:
        """The ribbon, cut to the inextensible catenary, starts at rest in the discrete
        catenary its column promises (elastic: band stiffness Y WIDTH; ``production``:
        inextensible) and hangs for 2 s (damped); its sag against that catenary. The start
        matters for the force-based integrators: their damping acts on strain rates only
        and leaves a chain's strain-free swinging undamped, so from another start they would
        still swing after seconds. A column whose equilibrium is elsewhere moves there."""
        fabric, material = chain(modulus)(column)
        solver = make_solver(column, fabric, material, frequency, strain_limit=0.0, **column.settling()[1])
        row_weight = 2 * CHAIN_DENSITY * LINK * WIDTH / 2 * G
        stiffness = modulus * WIDTH if column.elastic else math.inf
        nodes = elastic_catenary(MASSES, LINK, SPAN, row_weight, stiffness)
        start_at(solver, np.column_stack([np.repeat(nodes, 2, axis=0), np.tile([0.0, WIDTH], MASSES + 2)]))
        run(solver, 2.0)
        return abs(-positions(solver)[:, 1].min() / -nodes[:, 1].min() - 1.0)

    return measure


# ---------------------------------------------------------------------------------- static stretch
ROWS, STRIP_MODULUS = 6, 20.0


def strip(column: Column):
    """A ribbon of ROWS rows hanging straight down from its pinned top row."""
    points = np.column_stack([np.zeros(ROWS), -LINK * np.arange(ROWS)])
    material = Material(areal_density=CHAIN_DENSITY, stretch_modulus=STRIP_MODULUS, shear_modulus=STRIP_MODULUS / 1000,
                        bend_modulus=0.0, damping=column.settling()[0], drag_coefficient=0.0)
    return ribbon(points, WIDTH, pinned_rows=(0,), shearing=False), material


def static_stretch(column: Column, frequency: float) -> float:
    """The strip's stretch after 3 s against linear elasticity: band j stretches by
    LINK W_j / (Y WIDTH), W_j the weight of the rows below it (the hanging mass). ``production``
    promises zero stretch: its error is its stretch relative to the elastic one."""
    fabric, material = strip(column)
    solver = make_solver(column, fabric, material, frequency, strain_limit=0.0, **column.settling()[1])
    row_weight = 2 * CHAIN_DENSITY * LINK * WIDTH / 2 * G
    below = row_weight * np.arange(ROWS - 1, 0, -1)
    elastic = float((LINK * below / (STRIP_MODULUS * WIDTH)).sum())
    run(solver, 3.0)
    stretch = -positions(solver)[:, 1].min() - LINK * (ROWS - 1)
    expected = elastic if column.elastic else 0.0
    return abs(stretch - expected) / elastic


# ---------------------------------------------------------------------------------- incline
MU, THICKNESS, INCLINE_SECONDS = 0.5, 0.002, 0.5


def incline(degrees: float):
    def measure(column: Column, frequency: float) -> float:
        """A particle at rest on a plane tilted by ``degrees`` with friction MU: below the
        friction angle atan(MU) it sticks (error: its slide relative to a frictionless one,
        g sin t^2 / 2), above it slides at a = g (sin - MU cos) (error: relative to a)."""
        theta = math.radians(degrees)
        normal = np.array([-math.sin(theta), math.cos(theta), 0.0])
        down = np.array([-math.cos(theta), -math.sin(theta), 0.0])
        material = Material(areal_density=1.0, thickness=THICKNESS, damping=0.0, friction=MU)
        solver = make_solver(column, single_particle(normal * THICKNESS), material, frequency,
                             colliders=half_space(normal, MU))
        start = positions(solver)[0]
        run(solver, INCLINE_SECONDS)
        slide = float((positions(solver)[0] - start) @ down)
        accel = G * (math.sin(theta) - MU * math.cos(theta))
        if accel <= 0:
            return abs(slide) / (0.5 * G * math.sin(theta) * INCLINE_SECONDS**2)
        return abs(2 * slide / INCLINE_SECONDS**2 / accel - 1.0)

    return measure


# ---------------------------------------------------------------------------------- momentum
DRIFT = np.array([0.3, -0.2, 0.1])


def free_cloth(column: Column):
    fabric = cooked_sheet(5, 5, 0.1, plane="XZ")
    material = Material(areal_density=0.15, damping=0.1, drag_coefficient=0.0, stretch_modulus=50.0,
                        shear_modulus=5.0, bend_modulus=1e-6)
    return fabric, material


def momentum(column: Column, frequency: float) -> float:
    """A free 5 x 5 cotton-like cloth (damping 0.1, no gravity, still air) drifting at DRIFT
    gets random internal velocities of zero total momentum: 0.25 s later sum m v is still
    M DRIFT and the centre of mass has moved on a straight line (error relative to M |DRIFT|,
    plus the centre's distance from its line over the drift's path)."""
    fabric, material = free_cloth(column)
    solver = make_solver(column, fabric, material, frequency, gravity=(0.0, 0.0, 0.0), initial_velocity=DRIFT,
                         strain_limit=0.0)
    h = iteration_length(frequency)
    run(solver, 1.0 / FPS)
    mass = masses(solver)
    internal = np.random.default_rng(3).normal(0.0, 0.3, (mass.size, 3))
    internal -= mass @ internal / mass.sum()
    add_velocity(solver, internal, h)
    spread = float(mass @ np.linalg.norm(internal, axis=1))
    centre0 = mass @ positions(solver) / mass.sum()
    seconds = 0.25
    run(solver, seconds, first=2)
    v = velocities(solver, h)
    drift = np.linalg.norm(DRIFT) * mass.sum()
    p_error = np.abs(mass @ v - mass.sum() * DRIFT).max() / drift
    line_error = np.abs(mass @ positions(solver) / mass.sum() - centre0 - DRIFT * seconds).max() / (np.linalg.norm(DRIFT) * seconds)
    worked = float(mass @ np.linalg.norm(v - mass @ v / mass.sum(), axis=1))
    assert worked < 0.9 * spread, f"{column.name}: the internal motion ({spread:.3g} -> {worked:.3g}) was not evened out"
    return max(p_error, line_error)


# ---------------------------------------------------------------------------------- motion constraint
RADIUS = 0.05


def max_distance(column: Column, frequency: float) -> float:
    """A particle painted with a 5 cm max distance falls from rest and stays on its sphere's
    lowest point, RADIUS below its rest position (error relative to RADIUS)."""
    from tests.physics.conftest import fabric_from_arrays

    fabric = fabric_from_arrays([[0.0, 1.0, 0.0]], [1.0], max_distance=[RADIUS])
    solver = make_solver(column, fabric, Material(areal_density=1.0, damping=0.0), frequency)
    run(solver, 0.5)
    return float(np.linalg.norm(positions(solver)[0] - [0.0, 1.0 - RADIUS, 0.0])) / RADIUS


LADDER = (240.0, 480.0, 960.0, 1920.0)
CASES = [
    Case("free fall", free_fall, LADDER, floor=1e-9, bound=2e-3),
    Case("drag terminal speed", terminal_speed, (480.0, 960.0, 1920.0, 3840.0), floor=1e-3, bound=0.01, scene=air_sheet),
    Case("pendulum period", pendulum_period, LADDER, floor=1e-4, bound=1e-3, scene=plate),
    Case("catenary sag", catenary_sag(1e4), LADDER, floor=1e-4, bound=1e-3, scene=chain(1e4)),
    Case("elastic catenary sag", catenary_sag(20.0), LADDER, floor=1e-3, bound=0.01, scene=chain(20.0)),
    Case("static stretch", static_stretch, LADDER, floor=1e-3, bound=0.02, scene=strip),
    # explicit: its contact removes the sliding velocity after the position update, so a
    # sticking particle creeps g sin h^2 per step, 2 h / t of a frictionless slide (first order)
    Case("incline sticks (20 deg)", incline(20.0), LADDER, floor=1e-6, bound=2.5e-3),
    Case("incline slides (40 deg)", incline(40.0), LADDER, floor=1e-3, bound=0.02),
    # implicit: the conjugate-gradient solve stops at a relative residual of 1e-6 (its
    # preset's cg_tolerance), which is what it leaves of the momentum
    Case("momentum of a free cloth", momentum, LADDER, floor=2e-6, bound=2e-6, scene=free_cloth),
    Case("max distance holds", max_distance, LADDER, floor=1e-6, bound=1e-3, requires=frozenset({"motion"})),
]


def ladder(case: Case, column: Column) -> tuple:
    if case.scene is None:
        return case.ladder
    fabric, material = case.scene(column)
    return explicit_frequencies(column, fabric, material, case.ladder)


def measured(case: Case, column: Column) -> dict[float, float]:
    return {f: case.measure(column, f) for f in ladder(case, column)}


def convergence_failures(case: Case, errors: dict[float, float]) -> list[str]:
    failed = []
    rungs = sorted(errors)
    for coarse, fine in zip(rungs, rungs[1:]):
        if errors[coarse] > case.floor and not errors[fine] <= CONVERGENCE * errors[coarse]:
            failed.append(f"{coarse:g} -> {fine:g} Hz: {errors[coarse]:.3g} -> {errors[fine]:.3g}")
    if not errors[rungs[-1]] <= case.bound:
        failed.append(f"{rungs[-1]:g} Hz: {errors[rungs[-1]]:.3g} > bound {case.bound:g}")
    return failed


@pytest.mark.parametrize("column", columns(), ids=lambda c: c.name)
@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_case_converges_for_every_integrator(case, column):
    reason = skip_reason(column, case.requires)
    if reason is not None:
        pytest.skip(f"{case.name}: {reason}")
    errors = measured(case, column)
    failed = convergence_failures(case, errors)
    table = ", ".join(f"{f:g} Hz {e:.3g}" for f, e in errors.items())
    assert not failed, f"{case.name} x {column.name}: {'; '.join(failed)} (errors: {table})"
