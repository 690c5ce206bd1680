"""Air resistance in still air only takes energy away.

Drag opposes a triangle's motion through the air and lift acts at right angles to it, so
without gravity, wind or pins a cloth moving through still air can only lose kinetic energy
(constraints between its particles do not add any either). The cloth is a flat 8 x 8 sheet
thrown at 2 m/s along its normal, the direction of the strongest drag.
"""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.settings import SolverConfig, load_material



@pytest.mark.parametrize(
    "preset",
    ["cotton", "denim", "jersey", "leather", "silk"],
)
def test_still_air_never_adds_kinetic_energy(preset, grid_fabric, solver_for):
    fabric = grid_fabric(8, 8, 0.05, plane="XZ")  # normal along Y
    frequency, fps = 300, 60
    solver = solver_for(
        fabric, load_material(preset, "test"), SolverConfig(frequency=frequency), gravity=(0.0, 0.0, 0.0),
        initial_velocity=(0.0, 2.0, 0.0),
    )
    assert "wind" in solver.stage_names
    mass = solver.model.mass
    h = 1.0 / frequency
    energy = [0.5 * mass.sum() * 2.0**2]
    dt = 1.0 / fps
    for frame in range(1, fps // 2 + 1):  # 0.5 s
        solver.step(frame, (frame - 1) * dt, dt)
        velocity = (solver.state.cur[:, :3].astype(np.float64) - solver.state.prev[:, :3]) / h
        energy.append(0.5 * float(mass @ (velocity * velocity).sum(axis=1)))
    energy = np.array(energy)
    bad = np.flatnonzero(~np.isfinite(energy))
    assert bad.size == 0, f"non-finite velocities from frame {bad[0]}"
    gained = np.flatnonzero(energy[1:] > energy[:-1] * (1.0 + 1e-6))
    assert gained.size == 0, (
        f"kinetic energy grew in frames {(gained + 1).tolist()[:5]}: "
        f"{energy[gained[0]]:.3g} -> {energy[gained[0] + 1]:.3g} J"
    )
    assert energy[-1] < 0.5 * energy[0]  # and the air did brake the cloth
