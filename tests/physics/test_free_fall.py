"""Free fall: x(t) = x0 + v0 t + g t^2 / 2, at every solver frequency and frame rate.

The solver starts Verlet with x_{-1} = x_0 - v0 h + g h^2 / 2, which makes position Verlet
exact for a constant acceleration (x_{n+1} = 2 x_n - x_{n-1} + g h^2 has the parabola as its
exact solution), so the only error left is rounding. In float64 state that is ~1e-8 relative
(the gravity term g h^2 is still rounded to float32); in float32 state it is bounded by
``verlet_rounding_bound`` below. A start without the g h^2 / 2 term misses by g h t / 2 (a
relative error h / t): over 0.5 s at 300 Hz that is 8 mm, 12 times the float32 bound.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from clothtool.settings import SolverConfig, load_material

EPS32 = float(np.finfo(np.float32).eps)
G = np.array([0.0, -9.81, 0.0])
V0 = np.array([1.0, 3.0, -0.5])


def verlet_rounding_bound(extent: float, steps: int, seconds: float) -> float:
    """Worst-case float32 rounding of N Verlet steps x' = fl(fl(x + d) + b) on coordinates of
    magnitude <= extent: each step rounds by at most eps * extent (two half-ulps); Verlet
    carries an error made at step k into every later step as a velocity error, so by step N it
    has grown (N - k + 1)-fold: sum = eps * extent * N (N + 1) / 2 < eps * extent (N + 1)^2 / 2.
    The float32 rounding of g h^2 (relative eps / 2) adds at most eps |g| t^2 / 4."""
    return EPS32 * extent * (steps + 1) ** 2 / 2 + EPS32 * float(np.linalg.norm(G)) * seconds**2


def ballistic(x0: np.ndarray, t: float) -> np.ndarray:
    return x0 + V0 * t + 0.5 * G * t * t


def path_extent(x0: np.ndarray, seconds: float) -> float:
    """Largest coordinate magnitude along the exact paths of points x0 (k,3)."""
    times = np.linspace(0.0, seconds, 200)
    return float(max(np.abs(ballistic(x0, t)).max() for t in times))


# (solver frequency, fps): whole and rounded iteration counts per frame (25 fps at 300 Hz is
# 12 iterations of 1/300 s; 24 fps at 120 Hz is 5)
FLOAT32_RATES = [(60, 60), (120, 24), (240, 48), (300, 60), (300, 25)]


@pytest.mark.parametrize("frequency, fps", FLOAT32_RATES)
def test_free_particle_float32_matches_half_g_t_squared(frequency, fps, build_fabric, solver_for, simulate):
    fabric = build_fabric([[0.0, 0.0, 0.0]], [1.0])
    config = SolverConfig(frequency=frequency, precision="float32")
    solver = solver_for(fabric, config=config, gravity=G, initial_velocity=V0)
    t = simulate(solver, fps, int(0.5 * fps))
    steps = int(round(t * frequency))
    error = np.abs(solver.world_points()[0].astype(np.float64) - ballistic(np.zeros(3), t)).max()
    bound = verlet_rounding_bound(path_extent(np.zeros((1, 3)), t), steps, t)
    assert error <= bound, (
        f"free fall off by {error:.3g} m after {t} s ({steps} steps); float32 rounding allows {bound:.3g} m"
    )


@pytest.mark.parametrize("frequency, fps", [(60, 60), (120, 24), (300, 60), (600, 30), (1200, 60)])
def test_free_particle_float64_matches_half_g_t_squared(frequency, fps, build_fabric, solver_for, simulate):
    fabric = build_fabric([[0.0, 0.0, 0.0]], [1.0])
    config = SolverConfig(frequency=frequency, precision="float64")
    solver = solver_for(fabric, config=config, gravity=G, initial_velocity=V0)
    t = simulate(solver, fps, fps)  # one second
    exact = ballistic(np.zeros(3), t)
    error = np.abs(solver.world_points()[0] - exact).max()
    assert error <= 1e-6 * np.abs(exact).max(), f"free fall off by {error:.3g} m after {t} s at {frequency} Hz"


@pytest.mark.parametrize("preset", ["cotton", "denim", "jersey"])
@pytest.mark.parametrize("precision", ["float32", "float64"])
@pytest.mark.parametrize("frequency, fps", [(120, 24), (300, 60)])
def test_unpinned_cloth_centre_of_mass_accelerates_at_g(
    preset, precision, frequency, fps, grid_fabric, solver_for, simulate
):
    """Constraints are internal forces: an unpinned cloth's centre of mass falls exactly like a
    particle, and a uniform acceleration does not deform it (no constraint is violated)."""
    fabric = grid_fabric(6, 6, 0.1)
    # no air resistance (presets have drag), no damping: nothing but gravity acts
    material = dataclasses.replace(
        load_material(preset, "test"), damping=0.0, drag_coefficient=0.0, lift_coefficient=0.0
    )
    config = SolverConfig(frequency=frequency, precision=precision)
    solver = solver_for(fabric, material, config, gravity=G, initial_velocity=V0)
    inv_mass = solver.model.inv_mass.astype(np.float64)
    mass = 1.0 / inv_mass  # the masses the solver weighs its corrections with
    rest = solver.model.rest_pos.astype(np.float64)
    com0 = mass @ rest / mass.sum()
    t = simulate(solver, fps, int(0.5 * fps))
    points = solver.world_points().astype(np.float64)
    com = mass @ points / mass.sum()
    exact = ballistic(com0, t)
    if precision == "float32":
        tolerance = verlet_rounding_bound(path_extent(rest, t), int(round(t * frequency)), t)
    else:
        tolerance = 1e-6 * np.abs(exact - com0).max()
    error = np.abs(com - exact).max()
    assert error <= tolerance, f"centre of mass off by {error:.3g} m after {t} s (allowed {tolerance:.3g})"
    # rigid translation: every particle sits at its rest position plus the common drop (to 2e-5
    # of the 0.1 m spacing: NvCloth's FLT_EPSILON in |h|^2 shortens each 0.1 m edge by 0.6 um,
    # see test_log_stiffness.py)
    drift = np.abs(points - (rest + (exact - com0))).max()
    assert drift <= tolerance + 2e-6, f"the cloth deformed by {drift:.3g} m while falling freely"
