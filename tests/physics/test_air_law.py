"""The air law in every integrator against the textbook, from one table of cases.

Drag on a flat plate moving face-on through still air is F = 1/2 rho C_d A v^2, so a sheet of
areal density sigma falling face-on reaches v_t = sqrt(2 sigma g / (rho C_d)) (the sheet's
area cancels), approached as v_t tanh(g t / v_t). Without gravity a sheet thrown face-on at
u0 slows as u0 / (1 + k u0 t), k = rho C_d / (2 sigma). A strip pinned along its top edge in
a horizontal wind W hangs straight at the angle phi from the vertical where the force per
area has no part along the strip's normal n:

    1/2 rho W^2 (C_d cos^2 phi + C_l cos phi sin^2 phi) = sigma g sin phi

(drag 1/2 rho C_d W^2 |cos| along the wind, lift 1/2 rho C_l W^2 cos sin at right angles to
it, cos = n . w / W = cos phi). Each answer is computed here in float64 from those formulas,
independent of the solvers' code. The position-based solver's wind stage sees the motion of
an iteration after gravity's push (and, triangle by triangle, after the pushes of the
triangles before it), so it falls slower by a fraction of g h: about 0.6 g h / v_t, 1.4% at
240 Hz, halving with each doubling of the frequency (the bounds below); the explicit and
implicit integrators reach v_t itself at a steady fall (their force balance has no h).
The sheet is a quad mesh: its particles' shares in the air force follow their lumped masses
(clothtool.solver.air), or it would crumple instead of falling flat.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from clothtool.integrators.explicit.solver import ExplicitClothSolver
from clothtool.integrators.explicit.stability import stability_limit
from clothtool.integrators.implicit.solver import ImplicitClothSolver
from clothtool.profile import StageProfiler
from clothtool.settings import Material, PhaseSettings, Placement, SolverConfig
from clothtool.solver.cloth import ClothSolver
from clothtool.solver.environment import Environment
from clothtool.solver.model import build_model

SOLVERS = {"pbd": ClothSolver, "implicit": ImplicitClothSolver, "explicit": ExplicitClothSolver}
RHO, G, FPS = 1.2, 9.81, 24.0
# cotton's density and air coefficients; soft enough (10 N/m) for the explicit integrator
# at 240 Hz on 10 cm particles; no damping: NvCloth's damping slows every motion and would
# lower the terminal speed
COTTON_AIR = Material(
    areal_density=0.15, drag_coefficient=0.8, lift_coefficient=0.3, damping=0.0,
    stretch_modulus=10.0, shear_modulus=1.0, bend_modulus=1e-6, bending=PhaseSettings(stiffness=0.2),
)
FALL_SPEED = math.sqrt(2 * COTTON_AIR.areal_density * G / (RHO * COTTON_AIR.drag_coefficient))  # 1.751 m/s

# (integrator, precision, frequency Hz, largest relative error of the terminal speed): the
# bound halves as the frequency doubles and ends well within 1%; at 3840 Hz the seed's speed
# cut-off (1.33 m/s) would have switched the drag off. float64 state: float32 positions of a
# metre or two resolve ~1e-7 m, a few times less than gravity's step g h^2 at 3840 Hz, and
# their rounding (it sets an undamped sheet fluttering), not the law, would dominate the
# 0.1% figures; the production precision is checked where it resolves the motion.
CASES = [
    (integrator, "float64", frequency, bound)
    for integrator in SOLVERS
    for frequency, bound in ((240, 0.02), (480, 0.01), (960, 0.005), (1920, 0.0025), (3840, 0.00125))
] + [(integrator, "float32", frequency, bound) for integrator in SOLVERS for frequency, bound in ((240, 0.02), (480, 0.01))]


def sheet(grid_fabric, pinned_top: bool = False):
    """A 4 x 4 sheet of 10 cm squares; horizontal (normal along Y), or hanging in the XY
    plane from its top row."""
    if not pinned_top:
        return grid_fabric(4, 4, 0.1, plane="XZ")
    return grid_fabric(4, 8, 0.05, plane="XY", pin_box=(-1.0, -0.01, -1.0, 1.0, 1.0, 1.0))


def solver(integrator, fabric, frequency, gravity=(0.0, -G, 0.0), wind=None, damping=0.0, lift=0.0,
           precision="float64", **kwargs):
    """A solver of ``integrator`` for ``fabric`` in COTTON_AIR with this damping and lift (a
    falling plate with lift is unstable: it tilts and glides, as real paper does)."""
    material = Material(**{**COTTON_AIR.__dict__, "damping": damping, "lift_coefficient": lift})
    model = build_model("cloth", fabric, material, Placement(), 1.0, "Y")
    config = SolverConfig(frequency=frequency, integrator=integrator, strain_limit=0.0, precision=precision)
    air = None if wind is None else (lambda t: np.asarray(wind, np.float64))
    environment = Environment(gravity=np.asarray(gravity, np.float64), wind=air, fluid_density=RHO)
    if integrator == "explicit":
        assert 1.0 / frequency < stability_limit(model, environment)
    return SOLVERS[integrator](model, config, environment, StageProfiler(), **kwargs)


def mean_velocity(s, frequency) -> np.ndarray:
    """Mass-weighted mean velocity (3,) of the free particles over the last iteration."""
    mass = np.where(s.model.inv_mass > 0, s.model.mass, 0.0)
    return mass @ s.world_velocities(1.0 / frequency).astype(np.float64) / mass.sum()


def run(s, seconds: float) -> None:
    for frame in range(1, round(seconds * FPS) + 1):
        s.step(frame, (frame - 1) / FPS, 1.0 / FPS)


@pytest.mark.parametrize("integrator, precision, frequency, bound", CASES)
def test_falling_sheet_reaches_the_textbook_terminal_speed(integrator, precision, frequency, bound, grid_fabric):
    s = solver(integrator, sheet(grid_fabric), frequency, precision=precision)
    assert "wind" in s.stage_names or integrator == "implicit"  # the implicit solve has no stage of its own
    run(s, 1.25)  # seven time constants v_t / g: tanh is within 2e-6 of 1
    velocity = mean_velocity(s, frequency)
    error = -velocity[1] / FALL_SPEED - 1.0
    assert abs(error) <= bound, f"{integrator} at {frequency} Hz: {-velocity[1]:.4f} m/s, textbook {FALL_SPEED:.4f}"
    assert np.abs(velocity[[0, 2]]).max() < 1e-3 * FALL_SPEED  # straight down


@pytest.mark.parametrize("integrator", SOLVERS)
def test_slow_sheet_coasting_at_high_frequency_slows_as_the_quadratic_law(integrator, grid_fabric):
    """No gravity, thrown face-on at 0.5 m/s, at 3840 Hz: the seed's cut-off would have left
    it coasting at 0.5 m/s; the law slows it to u0 / (1 + k u0 t)."""
    frequency, u0, seconds = 3840.0, 0.5, 0.5
    s = solver(integrator, sheet(grid_fabric), frequency, gravity=(0.0, 0.0, 0.0), initial_velocity=(0.0, u0, 0.0))
    run(s, seconds)
    k = RHO * COTTON_AIR.drag_coefficient / (2 * COTTON_AIR.areal_density)
    np.testing.assert_allclose(mean_velocity(s, frequency)[1], u0 / (1 + k * u0 * seconds), rtol=0.01)


def hanging_angle(wind_speed: float) -> float:
    """phi (radians from the vertical) of the module docstring's balance."""
    q = 0.5 * RHO * wind_speed**2
    cd, cl, weight = COTTON_AIR.drag_coefficient, COTTON_AIR.lift_coefficient, COTTON_AIR.areal_density * G

    def normal_force(phi):
        c, s = math.cos(phi), math.sin(phi)
        return q * (cd * c * c + cl * c * s * s) - weight * s

    return brentq(normal_force, 0.0, math.pi / 2)


@pytest.mark.parametrize("integrator", SOLVERS)
def test_strip_pinned_in_wind_hangs_at_the_angle_of_the_same_law(integrator, grid_fabric):
    """A still strip pinned along its top edge in a 1.5 m/s wind (moving air, the same law as
    moving cloth) settles straight at the angle where weight, drag and lift balance."""
    wind_speed, frequency = 1.5, 1920.0
    fabric = sheet(grid_fabric, pinned_top=True)
    s = solver(integrator, fabric, frequency, wind=(0.0, 0.0, wind_speed), damping=0.1,
               lift=COTTON_AIR.lift_coefficient)
    run(s, 3.0)
    points = s.world_points().astype(np.float64)
    pinned = s.model.inv_mass == 0
    bottom = points[:, 1] < points[~pinned, 1].min() + 1e-3
    along = points[bottom].mean(axis=0) - points[pinned].mean(axis=0)
    angle = math.atan2(along[2], -along[1])  # the strip hangs in the XY plane, the wind along its normal Z
    expected = hanging_angle(wind_speed)
    assert 0.4 < expected < 0.8  # a clear lean, well short of flying flat
    assert abs(angle - expected) < math.radians(0.5), f"{math.degrees(angle):.2f} vs {math.degrees(expected):.2f} degrees"
    assert np.linalg.norm(mean_velocity(s, frequency)) < 0.01  # settled
