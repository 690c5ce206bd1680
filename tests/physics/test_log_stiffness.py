"""Log-space stiffness: a constraint error decays as e0 (1 - k)^(f_s t) at every frequency.

One distance constraint of rest length r between a pinned particle and a free one (mass 1 kg),
no gravity, damping 1 (the velocity scale (1 - 1)^(f_s h) is 0 in float32 at 60 Hz and below
4e-7 at 600 Hz, so the particle moves by projection only). Each iteration removes the
fraction k_h = 1 - (1 - k)^(f_s h) of the error, so after t seconds the error is
e0 (1 - k)^(f_s t) whatever h is (the seed's "Log Stiffness" section).

Once the error has decayed the constraint must rest at its rest length; at millimetre scale in
a metre scene it does not (last test).
"""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.settings import Material, PhaseSettings, SolverConfig

STIFFNESS_FREQUENCY = 100.0


def stretched_pair(build_fabric, solver_for, rest_length, stretched_to, stiffness, frequency):
    """Pinned particle 0 at the origin, free particle 1 at distance ``stretched_to`` along a
    skew direction; returns (solver, unit direction)."""
    direction = np.array([2.0, -3.0, 1.0]) / np.sqrt(14.0)
    fabric = build_fabric([[0.0, 0.0, 0.0], direction * rest_length], [0.0, 1.0], [[[0, 1]]])
    material = Material(areal_density=1.0, damping=1.0, vertical=PhaseSettings(stiffness=stiffness))
    config = SolverConfig(frequency=frequency, stiffness_frequency=STIFFNESS_FREQUENCY)
    solver = solver_for(fabric, material, config, gravity=(0.0, 0.0, 0.0))
    solver.state.cur[1, :3] = direction * stretched_to  # before the first step: x_prev follows
    return solver, direction


# (stiffness, seconds): decay to between 3 % and 50 % of e0
CASES = [(0.05, 0.5), (0.1, 0.2), (0.3, 0.1), (0.5, 0.05)]


@pytest.mark.parametrize("frequency", [60, 120, 300, 600])
@pytest.mark.parametrize("stiffness, seconds", CASES)
def test_constraint_error_decays_as_one_minus_k_to_the_fs_t(
    stiffness, seconds, frequency, build_fabric, solver_for, simulate
):
    rest_length, stretched_to = 0.5, 1.0
    solver, direction = stretched_pair(build_fabric, solver_for, rest_length, stretched_to, stiffness, frequency)
    e0 = stretched_to - rest_length
    t = simulate(solver, 20, int(round(seconds * 20)))  # 20 fps: 3 to 30 iterations per frame
    position = solver.state.cur[1, :3].astype(np.float64)
    error = np.linalg.norm(position) - rest_length
    expected = e0 * (1.0 - stiffness) ** (STIFFNESS_FREQUENCY * t)
    assert abs(error - expected) < 1e-4 * expected, (
        f"error {error:.6g} m after {t} s at {frequency} Hz, expected {expected:.6g} m"
    )
    # projection moves the particle along the constraint only
    assert np.linalg.norm(np.cross(position, direction)) < 1e-6
    assert expected < 0.5 * e0


@pytest.mark.parametrize(
    "rest_length",
    [
        0.5,
        0.05,
        0.002,  # NvCloth's FLT_EPSILON guard (scene units^2) used to leave this 1.5 % short
        0.0002,
    ],
)
def test_relaxed_constraint_rests_at_its_rest_length(rest_length, build_fabric, solver_for, simulate):
    """Stiffness 1, stretched by half its length: after 0.5 s the error is (1-1)^50 = 0 and the
    pair must sit at distance r (to 1e-4 of r)."""
    solver, _ = stretched_pair(build_fabric, solver_for, rest_length, 1.5 * rest_length, 1.0, 300)
    simulate(solver, 60, 30)
    distance = np.linalg.norm(solver.state.cur[1, :3].astype(np.float64))
    assert abs(distance - rest_length) < 1e-4 * rest_length, (
        f"a relaxed {rest_length} m constraint rests at {distance:.7g} m ({distance / rest_length - 1:+.3%})"
    )
