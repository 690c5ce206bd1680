"""Results converge as the solver frequency rises, far from the origin, in the default precision.

Each iteration adds a displacement of order g h^2 to a stored position: at 3840 Hz that is
6.7e-7 m, below half a float32 ulp of 40 m (1.9e-6 m), so float32 state stops converging
(a particle at y = 40 m does not fall at all) while float64 state keeps converging. Every
test here runs a frequency ladder whose tolerance shrinks as the frequency doubles, against
closed forms:

* free fall, y(t) = y0 - g t^2 / 2, for every integrator of one table. Position Verlet (pbd)
  with its exact start is exact for a constant acceleration, up to rounding; symplectic Euler
  (explicit) and backward Euler (implicit) drop g h^2 N (N + 1) / 2 in N steps, g h t / 2 too
  far, so their error halves as the frequency doubles;
* the centre of mass of a free cloth whose particles move against each other: constraints
  conserve sum m x, so it follows Verlet's discrete parabola exactly, up to rounding;
* a rigid pendulum's period, T = 4 sqrt(L / g) K(sin^2(theta0 / 2)): position-based
  projection loses energy at a rate O(h), so the period error halves as the frequency doubles;
* the README's swing study (against its converged float64 reference): the error falls at every
  doubling up to 6144 Hz.

The last tests check that float32 state can still be chosen and behaves as float32 rounding
predicts.
"""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np
import pytest
from scipy.special import ellipk

from clothtool.profile import StageProfiler
from clothtool.settings import Material, PhaseSettings, Placement, SolverConfig, load_solver
from clothtool.sim.integrators import integrator_spec
from clothtool.solver.environment import Environment
from clothtool.solver.model import build_model
from clothtool.study import StudyOptions, run_study
from clothtool.study.sweep import Sweep
from tests.conftest import EXAMPLES
from tests.physics.conftest import (
    cooked_grid,
    crossing_times,
    fabric_from_arrays,
    make_solver,
)

G = 9.81
SECONDS = 1.0
FPS = 60.0
HEIGHT = 40.0  # far from the origin: a float32 ulp here is 3.8e-6 m
LADDER = (480, 960, 1920, 3840, 7680)

# integrator -> error constant C: |free-fall error| <= C g h t at every rung, with h = 1/frequency.
# pbd is exact up to rounding (float64 rounding stays below 1e-7 m at 7680 Hz, C = 1e-3 allows
# 1.3e-6 m there); the Euler integrators miss by g h t / 2 (C = 1/2, plus 1% for rounding).
FREE_FALL = {"pbd": 1e-3, "implicit": 0.505, "explicit": 0.505}
FIRST_ORDER = {"implicit", "explicit"}  # error exactly g h t / 2: halves as the frequency doubles


def free_particle_solver(integrator: str, config: SolverConfig, y0: float):
    """One free particle of 1 kg at rest at (0, y0, 0) under gravity, for ``integrator``,
    built the way the bake builds it (the integrator registry)."""
    fabric = fabric_from_arrays([[0.0, y0, 0.0]], [1.0])
    model = build_model("particle", fabric, Material(areal_density=1.0, damping=0.0), Placement(), 1.0, "Y")
    environment = Environment(gravity=np.array([0.0, -G, 0.0]))
    extra = {"frame_dt": 1.0 / FPS} if integrator == "explicit" else {}
    solver_class = integrator_spec(integrator).load()
    return solver_class(model, config, environment, StageProfiler(), None, frozenset(), (0.0, 0.0, 0.0), **extra)


def free_fall_error(integrator: str, frequency: float, y0: float = HEIGHT, precision: str | None = None) -> float:
    """Signed error (m) of the particle's height after SECONDS against y0 - g t^2 / 2."""
    chosen = {} if precision is None else {"precision": precision}  # None: the default precision
    config = SolverConfig(frequency=frequency, integrator=integrator, **chosen)
    solver = free_particle_solver(integrator, config, y0)
    frames = round(SECONDS * FPS)
    for frame in range(1, frames + 1):
        solver.step(frame, (frame - 1) / FPS, 1.0 / FPS)
    return float(solver.world_points()[0, 1]) - (y0 - 0.5 * G * SECONDS**2)


@pytest.mark.parametrize("integrator", sorted(FREE_FALL))
def test_free_fall_converges_as_the_frequency_doubles(integrator):
    errors = [free_fall_error(integrator, frequency) for frequency in LADDER]
    for frequency, error in zip(LADDER, errors):
        allowed = FREE_FALL[integrator] * G * SECONDS / frequency
        assert abs(error) <= allowed, (
            f"{integrator}: free fall from y = {HEIGHT:g} m at {frequency} Hz off by {error:.3g} m "
            f"(allowed {allowed:.3g} m, shrinking with 1 / frequency)"
        )
    if integrator in FIRST_ORDER:
        ratios = [coarse / fine for coarse, fine in pairwise(errors)]
        assert all(1.9 <= r <= 2.1 for r in ratios), f"{integrator}: error ratios per doubling {ratios} (want 2)"


def test_default_presets_run_in_float64():
    """Every shipped solver preset keeps the default's float64 state."""
    for preset in ("preview", "production", "reference", "physical", "implicit", "explicit"):
        assert load_solver(preset, "test").precision == "float64", preset
    assert SolverConfig().precision == "float64"


def centre_of_mass_error(frequency: float, y0: float = HEIGHT, seconds: float = 0.5) -> float:
    """Largest coordinate error (m) of the centre of mass of a free 6 x 6 cloth at height y0
    whose particles were given random velocities of zero total momentum after the first frame,
    against Verlet's own closed form: with constraints conserving sum m x, the centre of mass
    c obeys c_{n+1} = 2 c_n - c_{n-1} + g h^2, so after N more iterations
    c_N = c_0 + N (c_0 - c_{-1}) + g h^2 N (N + 1) / 2 (computed here in float64)."""
    material = Material(areal_density=1.0, damping=0.0)
    placement = Placement(translation=np.array([0.0, y0, 0.0]))
    solver = make_solver(cooked_grid(6, 6, 0.1), material, SolverConfig(frequency=frequency),
                         gravity=(0.0, -G, 0.0), placement=placement)
    dt = 1.0 / FPS
    iterations = max(1, int(dt * frequency + 0.5))
    h = dt / iterations
    solver.step(1, 0.0, dt)
    state = solver.state
    mass = 1.0 / state.cur[:, 3].astype(np.float64)
    velocity = np.random.default_rng(1).normal(0.0, 0.5, (mass.size, 3))
    velocity -= (mass @ velocity) / mass.sum()  # internal motion only: no net momentum
    state.prev[:, :3] = (state.prev[:, :3].astype(np.float64) - velocity * h).astype(state.prev.dtype)
    start = mass @ state.cur[:, :3].astype(np.float64) / mass.sum()
    before = mass @ state.prev[:, :3].astype(np.float64) / mass.sum()
    frames = round(seconds * FPS)
    for frame in range(2, frames + 2):
        solver.step(frame, (frame - 1) * dt, dt)
    n = frames * iterations
    exact = start + n * (start - before) + np.array([0.0, -G, 0.0]) * h * h * n * (n + 1) / 2
    return float(np.abs(mass @ state.cur[:, :3].astype(np.float64) / mass.sum() - exact).max())


def test_free_cloth_centre_of_mass_converges_far_from_the_origin():
    """Measured in float64: 7e-11 m at 480 Hz to 1.2e-8 m at 7680 Hz (float32: 1.8 cm to 1.2 m,
    the cloth at 40 m barely falls); allowed 1e-3 g h t, 1e-5 .. 6.4e-7 m."""
    for frequency in LADDER:
        error = centre_of_mass_error(frequency)
        allowed = 1e-3 * G * 0.5 / frequency
        assert error <= allowed, (
            f"{frequency} Hz: free cloth's centre of mass at y = {HEIGHT:g} m off by {error:.3g} m (allowed {allowed:.3g} m)"
        )


# ---------------------------------------------------------------- pendulum
LENGTH = 1.0
THETA0 = math.radians(10.0)


def exact_period(theta0: float) -> float:
    return 4.0 * math.sqrt(LENGTH / G) * float(ellipk(math.sin(theta0 / 2.0) ** 2))


def period_error(frequency: float, mode: str, y0: float, precision: str | None = None) -> float:
    """Relative error of the mean of the first two periods of a bob on a rigid 1 m link hung
    from a pinned particle at (0, y0, 0), released from rest at THETA0. Sampled at 960 frames
    per second or the nearest rate with a whole number of iterations per frame."""
    pivot = [0.0, y0, 0.0]
    bob = [LENGTH * math.sin(THETA0), y0 - LENGTH * math.cos(THETA0), 0.0]
    fabric = fabric_from_arrays([pivot, bob], [0.0, 1.0], [[[0, 1]]])
    material = Material(areal_density=1.0, damping=0.0, stretch_modulus=math.inf, vertical=PhaseSettings(stiffness=1.0))
    chosen = {} if precision is None else {"precision": precision}  # None: the default precision
    config = SolverConfig(frequency=frequency, stiffness_mode=mode, **chosen)
    model = build_model("pendulum", fabric, material, Placement(), 1.0, "Y")
    solver = integrator_spec("pbd").load()(model, config, Environment(gravity=np.array([0.0, -G, 0.0])), StageProfiler())
    fps = frequency / math.ceil(frequency / 960.0)
    dt = 1.0 / fps
    frames = int(2.3 * exact_period(THETA0) * fps) + 1
    x = np.empty(frames)
    for frame in range(1, frames + 1):
        solver.step(frame, (frame - 1) * dt, dt)
        x[frame - 1] = float(solver.state.cur[1, 0])
    crossings = crossing_times(dt * np.arange(1, frames + 1), x)
    assert crossings.size >= 5, f"only {crossings.size} crossings of the vertical at {frequency} Hz"
    return (crossings[4] - crossings[0]) / 2.0 / exact_period(THETA0) - 1.0


# Measured in float64: -8.3e-5 at 480 Hz, halving to -6.1e-6 at 7680 Hz (both modes, either
# height); float32 is off by 1.6e-4 .. 4.7e-2 near the origin and loses the swing at 40 m.
PERIOD_CONSTANT = 0.06  # |relative period error| <= PERIOD_CONSTANT / frequency


@pytest.mark.parametrize("mode", ["nvcloth", "xpbd"])
def test_pendulum_period_converges_far_from_the_origin(mode):
    errors = [period_error(frequency, mode, HEIGHT) for frequency in LADDER]
    for frequency, error in zip(LADDER, errors):
        allowed = PERIOD_CONSTANT / frequency
        assert abs(error) <= allowed, (
            f"{mode}: pendulum at y = {HEIGHT:g} m, {frequency} Hz: period off by {error:+.3e} "
            f"(allowed {allowed:.2e}, shrinking with 1 / frequency)"
        )
    ratios = [coarse / fine for coarse, fine in pairwise(errors)]
    assert all(1.7 <= r <= 2.3 for r in ratios), f"{mode}: period error ratios per doubling {ratios} (want ~2)"


# ---------------------------------------------------------------- float32 stays selectable
def test_float32_state_is_selectable_and_rounds_as_float32():
    """In float32, g h^2 at 3840 Hz (6.65e-7 m) is below half an ulp of 40 m (1.9e-6 m): Verlet's
    x + (x - x_prev) + g h^2 rounds back to x at every iteration, so the particle never moves.
    Near the origin at 120 Hz a float32 particle falls within float32's rounding of the exact
    drop, as before float64 became the default."""
    config = SolverConfig(frequency=3840, precision="float32")
    solver = free_particle_solver("pbd", config, HEIGHT)
    assert solver.state.cur.dtype == np.float32
    h = 1.0 / 3840
    assert np.float32(G * h * h) < 0.5 * np.spacing(np.float32(HEIGHT))  # the prediction's premise
    for frame in range(1, 61):
        solver.step(frame, (frame - 1) / FPS, 1.0 / FPS)
    assert float(solver.world_points()[0, 1]) == HEIGHT, "float32 state at y = 40 m moved although g h^2 is below half an ulp"
    drop = 0.5 * G * SECONDS**2
    near = free_fall_error("pbd", 120, y0=1.0, precision="float32")
    # rounding bound of test_free_fall.py: eps * extent * (N + 1)^2 / 2 + eps g t^2, extent 3.9 m
    eps = float(np.finfo(np.float32).eps)
    bound = eps * (drop - 1.0) * 121**2 / 2 + eps * G * SECONDS**2
    assert abs(near) <= bound, f"float32 free fall near the origin off by {near:.3g} m (rounding allows {bound:.3g})"


# ---------------------------------------------------------------- the swing study
def test_swing_study_error_falls_monotonically_up_to_6144_hz():
    """The README's work-precision scene (examples/sheet/swing.toml, XPBD, first quarter
    second) in the default precision, against the study's converged float64 reference: the
    RMS position error falls at every doubling up to 6144 Hz. Measured: 1.9e-3, 5.3e-4,
    1.7e-4, 5.8e-5 of the cloth's size at 768..6144 Hz; in float32 it turns back up after
    1536 Hz (5.0e-4, 2.1e-3, 6.4e-3), where g h^2 nears a float32 ulp of the sheet's height."""
    physical = ('solver.preset="physical"',)
    options = StudyOptions(
        sweeps=(Sweep.parse("solver.frequency=768,1536,3072,6144"),), repeats=1,
        overrides=physical, reference=physical, frames=(1, 7),
    )
    result = run_study(EXAMPLES / "sheet" / "swing.toml", options)
    assert result.reference["converged"], f"the reference did not converge: {result.reference}"
    errors = [row["position_rms"] for row in result.rows]
    assert all(fine < coarse / 1.5 for coarse, fine in pairwise(errors)), (
        f"swing study RMS position error per frequency 768..6144 Hz: {errors} (want each doubling "
        "to cut it by at least 1.5x)"
    )
