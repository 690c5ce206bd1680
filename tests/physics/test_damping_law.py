"""Damping is specified per stiffness-frequency step, so it is independent of the solver's
frequency: a particle of a held cloth (one with a pinned particle) with velocity v0 and
damping d, without gravity, has velocity v0 (1 - d)^(f_s t) after t seconds, f_s being the
stiffness frequency, whatever the number of iterations that time is cut into. (Applying d per
iteration instead would give (1 - d)^(f t): at 600 Hz that is 6 times the decay exponent of
100 Hz.) A free cloth (nothing holds it) is damped relative to its mean motion, which keeps
its momentum (clothtool.solver.integrate): the same law holds for the particles' velocities
relative to their mass-weighted mean, and the mean does not change.
"""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.settings import Material, SolverConfig

V0 = np.array([2.0, -1.0, 0.5])
STIFFNESS_FREQUENCY = 100.0


@pytest.mark.parametrize("frequency", [60, 120, 300, 600])
@pytest.mark.parametrize("damping, seconds, fps", [(0.05, 0.2, 30), (0.2, 0.1, 30), (0.02, 0.2, 60)])
def test_velocity_decays_as_one_minus_d_to_the_fs_t(
    frequency, damping, seconds, fps, build_fabric, solver_for, simulate
):
    fabric = build_fabric([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0]], [1.0, 0.0])  # the second particle is pinned
    config = SolverConfig(frequency=frequency, stiffness_frequency=STIFFNESS_FREQUENCY)
    material = Material(areal_density=1.0, damping=damping)
    solver = solver_for(fabric, material, config, gravity=(0.0, 0.0, 0.0), initial_velocity=V0)
    t = simulate(solver, fps, int(round(seconds * fps)))
    h = 1.0 / fps / max(1, int(frequency / fps + 0.5))
    assert abs(h - 1.0 / max(frequency, fps)) < 1e-12  # the frequency really is the one under test
    velocity = (solver.state.cur[0, :3].astype(np.float64) - solver.state.prev[0, :3]) / h
    expected = V0 * (1.0 - damping) ** (STIFFNESS_FREQUENCY * t)
    error = np.abs(velocity - expected).max() / np.abs(expected).max()
    assert error < 1e-4, (
        f"velocity {velocity} after {t} s at {frequency} Hz, expected {expected} (relative error {error:.3g})"
    )
    assert np.abs(expected).max() < 0.8 * np.abs(V0).max()  # the decay is well resolved


@pytest.mark.parametrize("frequency", [60, 300, 600])
def test_free_cloth_damps_relative_motion_and_keeps_its_momentum(frequency, build_fabric, solver_for, simulate):
    """Two unlinked free particles of 1 and 3 kg moving at v_a and v_b: their mass-weighted
    mean velocity V stays, each one's velocity relative to V decays as (1 - d)^(f_s t)."""
    damping, fps, seconds = 0.05, 30, 0.2
    fabric = build_fabric([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], [1.0, 1.0 / 3.0])
    config = SolverConfig(frequency=frequency, stiffness_frequency=STIFFNESS_FREQUENCY)
    material = Material(areal_density=1.0, damping=damping)
    solver = solver_for(fabric, material, config, gravity=(0.0, 0.0, 0.0))
    h = 1.0 / fps / max(1, int(frequency / fps + 0.5))
    simulate(solver, fps, 1)  # one frame at rest, then the velocities (x_prev = x - v h)
    start = np.array([V0, -0.5 * V0])
    mass = 1.0 / solver.state.prev[:, 3].astype(np.float64)  # the solver's own: 1 / float32(1/3) for 3 kg
    solver.state.prev[:, :3] = solver.state.cur[:, :3] - start * h
    simulate(solver, fps, int(round(seconds * fps)), first=2)
    velocity = (solver.state.cur[:, :3].astype(np.float64) - solver.state.prev[:, :3]) / h
    mean = mass @ start / mass.sum()
    np.testing.assert_allclose(mass @ velocity / mass.sum(), mean, rtol=0, atol=1e-12)
    expected = mean + (start - mean) * (1.0 - damping) ** (STIFFNESS_FREQUENCY * seconds)
    np.testing.assert_allclose(velocity, expected, rtol=0, atol=1e-4 * np.abs(start).max())
    assert np.abs(expected - mean).max() < 0.5 * np.abs(start - mean).max()  # the decay is well resolved
