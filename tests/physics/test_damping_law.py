"""Damping is specified per stiffness-frequency step, so it is independent of the solver's
frequency: a free particle with velocity v0 and damping d, without gravity, has velocity
v0 (1 - d)^(f_s t) after t seconds, f_s being the stiffness frequency, whatever the number of
iterations that time is cut into. (Applying d per iteration instead would give
(1 - d)^(f t): at 600 Hz that is 6 times the decay exponent of 100 Hz.)
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
    fabric = build_fabric([[0.0, 0.0, 0.0]], [1.0])
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
