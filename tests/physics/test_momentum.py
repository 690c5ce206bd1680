"""Linear momentum of a free cloth is conserved (no gravity, no damping, no pins, still air).

A distance constraint moves its ends by dx_a = +c w_a h and dx_b = -c w_b h with the inverse
masses w, so m_a dx_a + m_b dx_b = 0 for any correction c: projections conserve sum m x
exactly, equal masses or not, and undamped Verlet carries sum m (x - x_prev) over unchanged.
So P = sum m v stays at its start value and the centre of mass moves in a straight line at
P / M. Masses are the solver's own, 1 / w.

Particles get random, different velocities (so the constraints work hard): the solver's
``initial_velocity`` is one vector for the whole cloth, so after one frame at rest the test
sets x_prev = x - v h itself.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from clothtool.fabric import PhaseType
from clothtool.settings import Material, SolverConfig, load_material

# (momentum drift relative to sum m |v|, centre-of-mass error in m). float32: every position
# update rounds by ~1e-7 of |x|, i.e. ~1e-5 m/s of velocity per particle and iteration at
# 300 Hz; summed over particles and iterations that reaches 5e-5 of sum m |v| here (light and
# heavy particles mixed). float64 rounding is 1e9 times finer: the drift is ~1e-14.
TOLERANCE = {"float32": (3e-4, 1e-6), "float64": (1e-10, 1e-12)}


def kick(solver, fps: float, velocities: np.ndarray) -> float:
    """One frame at rest (no forces: nothing moves), then give the particles ``velocities``;
    returns the iteration length h."""
    dt = 1.0 / fps
    solver.step(1, 0.0, dt)
    h = dt / max(1, int(dt * solver.config.frequency + 0.5))
    state = solver.state
    state.prev[:, :3] = state.cur[:, :3] - (velocities * h).astype(state.prev.dtype)
    return h


def momentum(solver, h: float) -> tuple[np.ndarray, float, np.ndarray, float]:
    """(P, sum m |v|, centre of mass, total mass) from the last iteration's displacement."""
    state = solver.state
    mass = 1.0 / state.prev[:, 3].astype(np.float64)
    velocity = (state.cur[:, :3].astype(np.float64) - state.prev[:, :3]) / h
    com = mass @ state.cur[:, :3].astype(np.float64) / mass.sum()
    return mass @ velocity, float(mass @ np.linalg.norm(velocity, axis=1)), com, float(mass.sum())


def ring_fabric(build_fabric, count: int, inv_mass: np.ndarray):
    """A closed ring of ``count`` (even) particles in the XY plane, linked to its neighbours
    and to the opposite particle (so it resists collapse): two conflict-free sets of
    neighbour links and one of diameters."""
    angle = 2.0 * np.pi * np.arange(count) / count
    pos = 0.3 * np.column_stack([np.cos(angle), np.sin(angle), np.zeros(count)])
    i = np.arange(count)
    even, odd = i[0::2], i[1::2]
    sets = [np.column_stack([even, (even + 1) % count]), np.column_stack([odd, (odd + 1) % count])]
    half = count // 2
    sets.append(np.column_stack([i[:half], i[:half] + half]))
    return build_fabric(pos, inv_mass, sets, PhaseType.HORIZONTAL)


CASES = ["grid", "ring-equal", "ring-unequal"]


@pytest.mark.parametrize("precision", ["float32", "float64"])
@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("frequency, fps", [(300, 60), (120, 24)])
def test_free_cloth_conserves_linear_momentum(
    case, precision, frequency, fps, build_fabric, grid_fabric, solver_for
):
    rng = np.random.default_rng(7)
    if case == "grid":  # cooked: corner, edge and interior particles differ in mass 1:2:4
        fabric = grid_fabric(6, 6, 0.1)
        material = load_material("cotton", "test")
    else:
        count = 16
        inv_mass = np.ones(count) if case == "ring-equal" else rng.uniform(0.1, 10.0, count)
        fabric = ring_fabric(build_fabric, count, inv_mass)
        material = Material(areal_density=1.0)
    # no damping and no air: nothing acts from outside
    material = dataclasses.replace(material, damping=0.0, drag_coefficient=0.0, lift_coefficient=0.0)
    config = SolverConfig(frequency=frequency, precision=precision)
    solver = solver_for(fabric, material, config, gravity=(0.0, 0.0, 0.0))
    assert solver.stage_names == ["integrate", "fabric"]
    velocities = rng.normal(0.0, 1.0, (fabric.particle_count, 3))
    h = kick(solver, fps, velocities)
    p0, scale, com0, total = momentum(solver, h)

    dt = 1.0 / fps
    for frame in range(2, 2 + fps):  # 1 s more
        solver.step(frame, (frame - 1) * dt, dt)
    p1, scale1, com1, _ = momentum(solver, h)

    tolerance, floor = TOLERANCE[precision]
    drift = np.abs(p1 - p0).max() / scale
    assert drift < tolerance, f"momentum {p0} -> {p1}: drift {drift:.3g} of sum m|v|"
    straight = com0 + p0 / total * 1.0  # 1 s later
    com_error = np.abs(com1 - straight).max()
    assert com_error < tolerance * scale / total + floor, (
        f"centre of mass off its straight line by {com_error:.3g} m"
    )
    # the constraints did work: the random velocities were largely evened out
    assert scale1 < 0.9 * scale, f"sum m|v| went from {scale:.3g} to {scale1:.3g}: the constraints did nothing"
