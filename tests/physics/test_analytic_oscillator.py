"""Spring oscillator: one free particle on one distance constraint to a pinned particle, no
gravity, no damping, displaced along the constraint (where the constraint is exactly linear).

In xpbd mode the constraint's spring constant comes from the material (see
``clothtool.solver.fabric.constraint_compliance``): k = stretch_modulus * A / L^2, A being the
mean lumped area of the two particles; the mass is areal_density times the free particle's
area. Both are computed here from those definitions, and the oscillation frequency must be
sqrt(k / m) / 2 pi within 1 %. XPBD with one iteration per substep is backward Euler in
position for this spring: its discrete frequency is atan(w h) / (2 pi h), a relative error of
(w h)^2 / 3, and its amplitude shrinks by 1 / sqrt(1 + (w h)^2) per step, which does not move
the zero crossings the frequency is measured from.

In nvcloth mode a stiffness removes a fixed fraction of the error per stiffness-frequency step,
so the per-iteration spring is k_h ~ -ln(1 - k) f_s h: the oscillation frequency grows as the
square root of the solver frequency (NvCloth's behaviour, kept on purpose), whereas xpbd's does
not depend on it.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from clothtool.settings import Material, PhaseSettings, SolverConfig
from clothtool.solver.fabric import constraint_compliance
from tests.physics.conftest import crossing_times, fabric_from_arrays, make_solver

REST = 0.5  # m
AREAS = (0.4, 0.3)  # m^2: lumped areas of the pinned and the free particle
DENSITY = 2.0  # kg/m^2: the free particle weighs 0.6 kg
DIRECTION = np.array([2.0, -3.0, 1.0]) / math.sqrt(14.0)
AMPLITUDE = 0.05  # m, along the constraint


def spring_constant(modulus: float) -> float:
    """k = modulus * A / L^2 (N/m), A the mean of the two particles' areas."""
    return modulus * 0.5 * (AREAS[0] + AREAS[1]) / REST**2


def mass() -> float:
    return DENSITY * AREAS[1]


def oscillator(mode: str, frequency: float, modulus: float, stiffness: float = 1.0, precision: str = "float64"):
    fabric = fabric_from_arrays([np.zeros(3), DIRECTION * REST], [0.0, 1.0 / AREAS[1]], [[[0, 1]]])
    fabric = dataclasses.replace(fabric, particle_area=np.asarray(AREAS, np.float32))
    fabric.validate()
    material = Material(
        areal_density=DENSITY, damping=0.0, stretch_modulus=modulus, vertical=PhaseSettings(stiffness=stiffness)
    )
    config = SolverConfig(frequency=frequency, stiffness_frequency=100.0, stiffness_mode=mode, precision=precision)
    solver = make_solver(fabric, material, config, gravity=(0.0, 0.0, 0.0))
    solver.state.cur[1, :3] = DIRECTION * (REST + AMPLITUDE)  # before the first step: x_prev follows
    return solver


def measured_frequency(
    mode: str, frequency: float, modulus: float, stiffness: float = 1.0, seconds: float = 4.0, precision: str = "float64"
) -> float:
    """Oscillation frequency (Hz) from the zero crossings of the extension, sampled at every
    iteration (one iteration per frame)."""
    solver = oscillator(mode, frequency, modulus, stiffness, precision)
    dt = 1.0 / frequency
    steps = int(round(seconds * frequency))
    extension = np.empty(steps)
    for frame in range(1, steps + 1):
        solver.step(frame, (frame - 1) * dt, dt)
        extension[frame - 1] = np.linalg.norm(solver.state.cur[1, :3].astype(np.float64)) - REST
    crossings = crossing_times(dt * np.arange(1, steps + 1), extension)
    assert crossings.size >= 4, f"only {crossings.size} zero crossings in {seconds} s"
    return (crossings.size - 1) / (2.0 * (crossings[-1] - crossings[0]))


def test_compliance_is_the_documented_mapping():
    """The xpbd stage's compliance is 1 / (modulus * A / L^2) for a stretch constraint."""
    solver = oscillator("xpbd", 300.0, 10.0)
    np.testing.assert_allclose(constraint_compliance(solver.model), [1.0 / spring_constant(10.0)], rtol=1e-6)


@pytest.mark.parametrize("precision", ["float32", "float64"])
@pytest.mark.parametrize("modulus, frequency", [(10.0, 60), (10.0, 300), (40.0, 120), (40.0, 1200)])
def test_xpbd_oscillates_at_sqrt_k_over_m(modulus, frequency, precision):
    exact = math.sqrt(spring_constant(modulus) / mass()) / (2.0 * math.pi)  # 0.77 Hz and 1.54 Hz
    measured = measured_frequency("xpbd", frequency, modulus, precision=precision)
    error = measured / exact - 1.0
    assert abs(error) < 0.01, f"{measured:.5f} Hz at {frequency} Hz, sqrt(k/m)/2pi = {exact:.5f} Hz ({error:+.3%})"


def test_nvcloth_frequency_depends_on_the_solver_frequency_xpbd_does_not():
    """Between 60 Hz and 600 Hz the nvcloth oscillator speeds up by about sqrt(10) (more than
    20 %), the xpbd one changes by less than 1 %."""
    nv = {f: measured_frequency("nvcloth", f, 10.0, stiffness=0.01) for f in (60, 600)}
    xp = {f: measured_frequency("xpbd", f, 10.0) for f in (60, 600)}
    assert nv[600] / nv[60] - 1.0 > 0.2, f"nvcloth: {nv[60]:.4f} Hz at 60 Hz, {nv[600]:.4f} Hz at 600 Hz"
    assert abs(xp[600] / xp[60] - 1.0) < 0.01, f"xpbd: {xp[60]:.4f} Hz at 60 Hz, {xp[600]:.4f} Hz at 600 Hz"
