"""Analytic scenes at full size: error against the solver frequency, for both stiffness modes.

    python benchmarks/accuracy/analytic.py [--frequencies 60,120,240,480,960,1920,3840] [--scenes NAME,...]

The scenes and their exact answers are those of tests/physics/test_analytic_*.py (the tests
assert the issue's tolerances at the settings they name; this prints how the error moves with
the solver frequency). One row per scene and frequency, one column per stiffness mode:

* oscillator: relative error of the oscillation frequency against sqrt(k/m) / 2 pi, k from the
  material's stretch modulus (nvcloth mode ignores the modulus: its stiffness 0.01 per 100 Hz
  step gives a frequency that grows as sqrt(solver frequency), shown against the same k);
* pendulum 90 / 150: relative error of the first full period against 4 sqrt(L/g) K(sin(theta0/2))
  (a rigid link: stiffness 1 in nvcloth mode, zero compliance in xpbd mode);
* spring chain: relative error of the total stretch against m g N (N+1) / 2k, 20 masses (nvcloth
  mode: stiffness 0.5 per 100 Hz step, which has no k, against the same k);
* sheet: largest error of the middle column's drop against the 1-D profile, relative to the
  bottom drop, 41 x 41 grid (nvcloth mode: stiffness 1);
* conical: the settled angle's error (degrees) in the spinning frame with damping, and the
  largest local-vs-world orbit difference (mm).
All float64 state; frames of 1/60 s (or shorter for the pendulum), so that every frequency in
the default list is a whole number of iterations per frame.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.physics

import numpy as np  # noqa: E402

from clothtool.settings import Material, PhaseSettings, SolverConfig  # noqa: E402
from tests.physics import test_analytic_conical_pendulum as conical  # noqa: E402
from tests.physics import test_analytic_oscillator as oscillator  # noqa: E402
from tests.physics import test_analytic_pendulum as pendulum  # noqa: E402
from tests.physics import test_analytic_sheet as sheet  # noqa: E402
from tests.physics.conftest import cooked_grid, fabric_from_arrays, make_solver  # noqa: E402

G = 9.81
MODES = ("nvcloth", "xpbd")


def oscillator_error(frequency: float, mode: str) -> str:
    exact = math.sqrt(oscillator.spring_constant(10.0) / oscillator.mass()) / (2.0 * math.pi)
    measured = oscillator.measured_frequency(mode, frequency, 10.0, stiffness=0.01, seconds=6.0)
    return f"{measured / exact - 1.0:+.3%}"


def pendulum_error(degrees: float):
    def error(frequency: float, mode: str) -> str:
        return f"{pendulum.period_error(math.radians(degrees), frequency, mode):+.3%}"

    return error


def chain_error(frequency: float, mode: str, masses: int = 20, link: float = 0.05, mass: float = 0.05, k: float = 400.0) -> str:
    n = masses + 1
    rest = np.zeros((n, 3))
    rest[:, 1] = -link * np.arange(n)
    inv_mass = np.full(n, 1.0 / mass)
    inv_mass[0] = 0.0
    links = np.column_stack([np.arange(masses), np.arange(1, n)])
    fabric = fabric_from_arrays(rest, inv_mass, [links[0::2], links[1::2]])
    fabric.particle_area[:] = mass
    material = Material(
        areal_density=1.0, damping=1.0 - math.exp(-8.0 / 100.0), stretch_modulus=k * link**2 / mass,
        vertical=PhaseSettings(stiffness=0.5),
    )
    config = SolverConfig(frequency=frequency, stiffness_mode=mode, precision="float64")
    solver = make_solver(fabric, material, config, gravity=(0.0, -G, 0.0))
    dt = 1.0 / 60.0  # frequencies 60 * 2^k: whole iterations per frame
    for frame in range(1, 8 * 60 + 1):
        solver.step(frame, (frame - 1) * dt, dt)
    points = solver.state.cur[:, :3].astype(np.float64)
    stretch = float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1) - link))
    exact = mass * G * masses * (masses + 1) / (2.0 * k)
    return f"{stretch / exact - 1.0:+.3%}"


def sheet_error(frequency: float, mode: str, n: int = 41) -> str:
    if mode == "xpbd":
        depth, drop, _ = sheet.hang_sheet(n, frequency, fps=60.0)
    else:  # the same sheet with NvCloth stiffness 1 everywhere
        spacing = sheet.SIZE / (n - 1)
        fabric = cooked_grid(n, n, spacing, plane="XY", pin_box=(-1.0, -1e-3, -1.0, 2.0, 1e-3, 1.0), tethers="none")
        material = Material(areal_density=sheet.DENSITY, damping=1.0 - math.exp(-6.0 / 100.0), drag_coefficient=0.0, lift_coefficient=0.0)
        solver = make_solver(fabric, material, SolverConfig(frequency=frequency, precision="float64"), gravity=(0.0, -G, 0.0))
        dt = 1.0 / 60.0
        for frame in range(1, 241):
            solver.step(frame, (frame - 1) * dt, dt)
        rest = solver.model.rest_pos.astype(np.float64)
        middle = np.flatnonzero(np.abs(rest[:, 0] - sheet.SIZE / 2) < 1e-6)
        depth = -rest[middle, 1]
        drop = rest[middle, 1] - solver.state.cur[middle, 1].astype(np.float64)
    exact = sheet.exact_drop(depth)
    return f"{np.abs(drop - exact).max() / exact.max():.2%}"


def conical_error(frequency: float, mode: str) -> str:
    del mode  # a rigid link: both modes make the same projection (see test_analytic_pendulum.py)
    settled = conical.orbit(frequency, 10.0, "local", damping=0.05, theta0=conical.THETA - math.radians(15.0))
    angle = math.degrees(conical.angle(settled[-30:]).mean() - conical.THETA)
    local = conical.orbit(frequency, 2.0, "local")
    world = conical.orbit(frequency, 2.0, "world")
    gap = max(
        np.abs(np.hypot(local[:, 0], local[:, 2]) - np.hypot(world[:, 0], world[:, 2])).max(),
        np.abs(local[:, 1] - world[:, 1]).max(),
    )
    return f"{angle:+.3f} deg, {gap * 1000:.3f} mm"


SCENES = {
    "oscillator": oscillator_error,
    "pendulum 90": pendulum_error(90.0),
    "pendulum 150": pendulum_error(150.0),
    "spring chain": chain_error,
    "sheet": sheet_error,
    "conical": conical_error,
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frequencies", default="60,120,240,480,960,1920,3840")
    parser.add_argument("--scenes", default="", help="comma-separated scene names (default: all)")
    args = parser.parse_args()
    chosen = [s.strip() for s in args.scenes.split(",") if s.strip()] or list(SCENES)
    frequencies = [float(f) for f in args.frequencies.split(",")]
    print(f"{'scene':<14} {'Hz':>6}  {'nvcloth':>24}  {'xpbd':>24}")
    start = time.perf_counter()
    for name in chosen:
        for frequency in frequencies:
            cells = [SCENES[name](frequency, mode) for mode in MODES]
            print(f"{name:<14} {frequency:>6g}  {cells[0]:>24}  {cells[1]:>24}", flush=True)
    print(f"{time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
