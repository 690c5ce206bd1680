"""How far the `physical` (XPBD) mode's stretch is from the material's, on a hanging sheet.

    python benchmarks/accuracy/physical_stretch.py [--frequencies 60,120,...] [--seconds 3]

The sheet of examples/sheet/swing.toml (1 m square, 25 x 25 particles, cotton: 0.15 kg/m^2,
stretch modulus 20 000 N/m) hangs straight down from its pinned top edge, damped (cotton's
own damping), for ``--seconds``; its elongation is the bottom row's mean drop below its rest
height, averaged over the last fifth of the bake (the table also shows the change from the
fifth before, to show it has settled).

Two answers it is compared with, neither computed by the solver:
* the material's, a 1-D strip under its own weight: sigma g L^2 / (2 E) = 36.8 um;
* the static equilibrium of the very spring network XPBD's compliances describe (stretch,
  shear and bending distance constraints, k = 1 / compliance), solved as one linear system
  K u = f with scipy: what XPBD converges to as the frequency rises (it differs from the
  strip's by the shear springs' share of the load).

Position-based dynamics with one constraint pass per iteration leaves an error of order
g h^2 n^2 on an n-row chain (the pass cannot carry the pin's correction down the sheet within
one iteration), so the elongation falls as the frequency squared until it meets the
material's. `production` (NvCloth stiffness 1) is printed beside it: it converges to zero
stretch; so does `physical` with geodesic tethers (the `garment` cook preset's; cotton's
tether_scale 1 holds every particle within its rest distance of the pin), the last column.
More constraint passes per iteration would not be cheaper than more iterations here: the
fabric stage is 81% of an iteration's time on this sheet (the bake's profile at 960 Hz), so
k passes cost almost k iterations but cut the g h^2 n^2 error by only k where k iterations cut
it by k^2. Runs in float64 (the default).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sparse
import scipy.sparse.linalg as splinalg

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from clothtool.bake import make_solvers  # noqa: E402
from clothtool.loading import load_scene  # noqa: E402
from clothtool.profile import StageProfiler  # noqa: E402
from clothtool.solver.fabric import constraint_compliance  # noqa: E402
from clothtool.study import _bake_once  # noqa: E402

SCENE = ROOT / "examples" / "sheet" / "swing.toml"
FPS = 60.0
G = 9.81


def hanging(preset: str, frequency: float, seconds: float, tethers: bool = False):
    frames = int(round(seconds * FPS))
    cook = ['cloth.sheet.cook.tethers="geodesic"'] if tethers else []
    return load_scene(SCENE, cook + [
        "cloth.sheet.rotate_euler=[0.0, 0.0, 0.0]", "cloth.sheet.material.damping=0.1",
        f"scene.fps={FPS!r}", f"scene.frames=[1, {frames + 1}]", f'solver.preset="{preset}"',
        f"solver.frequency={frequency!r}",
    ], None)


def bottom_row(rest: np.ndarray) -> np.ndarray:
    return np.flatnonzero(rest[:, 1] < rest[:, 1].min() + 1e-6)


def elongation(preset: str, frequency: float, seconds: float, tethers: bool = False) -> tuple[float, float, float]:
    """(settled elongation m, its change over the last fifth before, wall s)."""
    scene = hanging(preset, frequency, seconds, tethers)
    t0 = time.perf_counter()
    baked = _bake_once(scene)
    wall = time.perf_counter() - t0
    frames = sorted(baked.frames)
    rest = baked.frames[frames[0]][0]
    bottom = bottom_row(rest)
    drops = np.array([float(np.mean(rest[bottom, 1] - baked.frames[f][0][bottom, 1])) for f in frames])
    fifth = max(1, len(frames) // 5)
    last, before = drops[-fifth:].mean(), drops[-2 * fifth:-fifth].mean()
    return float(last), float(last - before), wall


def network_elongation() -> float:
    """Static elongation of XPBD's spring network (linearised at rest: the strain is 1e-5)."""
    scene = hanging("physical", 300.0, 1.0)
    solver = make_solvers(scene, StageProfiler())[0]
    model = solver.model
    rest = np.asarray(solver.world_points(), np.float64)  # the start pose, hanging in the x-y plane
    n = rest.shape[0]
    inv_mass = np.asarray(model.inv_mass, np.float64)
    pairs = model.constraint_indices
    k = 1.0 / constraint_compliance(model)
    d = rest[pairs[:, 1]] - rest[pairs[:, 0]]
    d /= np.linalg.norm(d, axis=1)[:, None]
    rows, cols, vals = [], [], []
    for (a, b), kc, dc in zip(pairs, k, d):
        if not np.isfinite(kc) or kc == 0:
            continue
        block = kc * np.outer(dc, dc)
        for i, j, s in ((a, a, 1), (b, b, 1), (a, b, -1), (b, a, -1)):
            for r in range(3):
                for c in range(3):
                    rows.append(3 * i + r)
                    cols.append(3 * j + c)
                    vals.append(s * block[r, c])
    stiffness = sparse.csr_matrix((vals, (rows, cols)), shape=(3 * n, 3 * n))
    free = np.flatnonzero(inv_mass > 0)
    mass = np.asarray(model.mass, np.float64)
    force = np.zeros((n, 3))
    force[:, 1] = -G * mass
    # the sheet hangs in the x-y plane: out of plane (z) the network has no stiffness and no load
    dof = np.array([3 * i + c for i in free for c in (0, 1)])
    u = splinalg.spsolve(stiffness[dof][:, dof].tocsc(), force.reshape(-1)[dof])
    moved = np.zeros((n, 3))
    moved.reshape(-1)[dof] = u
    bottom = bottom_row(rest)
    return float(-moved[bottom, 1].mean())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frequencies", default="60,120,240,480,960,1920,3840,7680,15360")
    parser.add_argument("--seconds", type=float, default=3.0)
    args = parser.parse_args()
    frequencies = [float(f) for f in args.frequencies.split(",")]
    scene = hanging("physical", 300.0, 1.0)
    material = scene.cloths[0].material
    strip = material.areal_density * G * 1.0 ** 2 / (2.0 * material.stretch_modulus)
    network = network_elongation()
    for preset, tethers in (("physical", False), ("production", False), ("physical", True)):
        elongation(preset, frequencies[0], 0.1, tethers)  # compile first: the table's times are bakes only
    print(f"hanging 1 m cotton sheet, 25 x 25 particles, {args.seconds:g} s, float64 state")
    print(f"material (1-D strip, sigma g L^2 / 2E): {strip * 1e6:.1f} um; XPBD spring network, static: "
          f"{network * 1e6:.1f} um")
    print(f"{'Hz':>6}  {'physical um':>12}  {'x strip':>8}  {'x network':>9}  {'settling um':>11}  "
          f"{'s/sim s':>8}  {'production um':>13}  {'+tethers um':>11}")
    for f in frequencies:
        physical, settling, wall = elongation("physical", f, args.seconds)
        production, _, _ = elongation("production", f, args.seconds)
        tethered, _, _ = elongation("physical", f, args.seconds, tethers=True)
        print(f"{f:6g}  {physical * 1e6:12.1f}  {physical / strip:8.2f}  {physical / network:9.2f}  "
              f"{settling * 1e6:11.2f}  {wall / args.seconds:8.4f}  {production * 1e6:13.1f}  {tethered * 1e6:11.3f}")


if __name__ == "__main__":
    main()
