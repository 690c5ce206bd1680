"""Self-collision cost: the grid stage's time per call against particle count, and the bake.

    python benchmarks/selfcollide.py [--sizes 32,64,128,256] [--calls 50] [--frames 60]
                                     [--bake-sizes 32,64,128,256] [--repeats 3]

Part 1 times ``SelfCollideStage.run`` (gather, hash grid, Jacobi response) on an N x N sheet
1 m across folded in half onto itself 0.5 distance apart, so every particle has contacts
(the worst case short of a crumpled ball); distance 0.9 x the particle spacing. It prints
the median and the fastest ms per call over ``--calls`` calls and the fastest ns per
particle, which stays flat when the cost is linear in the particle count (the fastest call
is the one to read on a busy machine: a parallel kernel waits for every thread).

Part 2 bakes benchmarks/bake.py's hanging sheet (pinned corners, geodesic tethers, cotton,
300 Hz at 60 fps, null output) with and without ``solver.self_collision`` and prints ms per
frame of both (the fastest of ``--repeats`` bakes each, JIT excluded) and the self-collide
stage's share. The stage runs on all cores from SolverConfig.parallel_threshold points
(20000 by default, so 256^2 is parallel and the smaller sizes serial); results are
identical either way.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from clothtool.bake import bake
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.fabric_file import write_fabric
from clothtool.loading import load_scene
from clothtool.mesh.shapes import grid
from clothtool.profile import StageProfiler
from clothtool.settings import Material, Placement, SolverConfig
from clothtool.solver.cloth import ClothSolver
from clothtool.solver.environment import Environment
from clothtool.solver.iteration import Iteration
from clothtool.solver.model import build_model
from clothtool.solver.selfcollide import SelfCollideStage

SCENE = """
[scene]
fps = 60.0
frames = [0, {frames}]
[solver]
preset = "production"
frequency = 300.0
self_collision = {self_collision}
[output]
attributes = []
[cloth.sheet]
fabric = "sheet.fabric.h5"
material = {{ preset = "cotton", self_collision_distance = {distance} }}
"""


def folded_stage(n: int) -> tuple[SelfCollideStage, float]:
    spacing = 1.0 / (n - 1)
    distance = 0.9 * spacing
    fabric = cook_fabric(grid(n, n, spacing, plane="XZ"), CookOptions(tethers="none")).fabric
    model = build_model("sheet", fabric, Material(self_collision_distance=distance), Placement(), 1.0, "Y")
    solver = ClothSolver(model, SolverConfig(self_collision=True), Environment(np.zeros(3)), StageProfiler())
    stage = next(s for s in solver.stages if isinstance(s, SelfCollideStage))
    pos = model.rest_pos.astype(np.float64)
    right = pos[:, 0] > 0.5
    pos[right, 0] = 1.0 - pos[right, 0]  # fold the right half over the left one
    pos[right, 1] = 0.5 * distance
    solver.state.cur[:, :3] = pos
    solver.state.prev[:, :3] = pos
    plan = solver.plan_frame(1, 0.0, 1.0 / 60.0)
    stage.warm_up()
    return stage, plan.h


def time_calls(n: int, calls: int) -> tuple[float, float]:
    """(median, fastest) seconds per call."""
    stage, _ = folded_stage(n)
    iteration = Iteration(0, 0.0, 0.2, 1.0, None)
    snapshot = stage.solver.state.cur.copy()
    times = []
    for _ in range(calls):
        stage.solver.state.cur[:] = snapshot  # every call sees the same folded state
        start = time.perf_counter()
        stage.run(iteration)
        times.append(time.perf_counter() - start)
    return statistics.median(times), min(times)


def bake_ms(n: int, frames: int, self_collision: bool, folder: Path, repeats: int) -> tuple[float, float]:
    spacing = 1.0 / (n - 1)
    pins = folder / "corners.txt"
    pins.write_text(f"0 {n - 1}\n")
    fabric = cook_fabric(grid(n, n, spacing), CookOptions(pin_file=str(pins), tethers="geodesic")).fabric
    write_fabric(fabric, folder / "sheet.fabric.h5")
    path = folder / "scene.toml"
    path.write_text(
        SCENE.format(frames=frames, self_collision=str(self_collision).lower(), distance=0.9 * spacing)
    )
    scene = load_scene(path)
    stats = min((bake(scene, "null") for _ in range(repeats)), key=lambda s: s.simulation_s)
    per_frame = {row["stage"]: row["per_frame_ms"] for row in stats.profile}
    return 1000.0 * stats.simulation_s / stats.frames_simulated, per_frame.get("self-collide", 0.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="32,64,128,256")
    parser.add_argument("--calls", type=int, default=50)
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--bake-sizes", default="32,64,128,256")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]

    print("self-collide stage on a folded sheet (every particle in contact)")
    print(f"{'N':>5} {'particles':>9} {'ms/call':>9} {'best ms':>9} {'best ns/particle':>16}")
    for n in sizes:
        median, best = time_calls(n, args.calls)
        print(f"{n:>5} {n * n:>9} {1000 * median:>9.3f} {1000 * best:>9.3f} {1e9 * best / (n * n):>16.1f}", flush=True)

    print()
    print(f"bake, hanging sheet, {args.frames} frames, 5 iterations per frame")
    print(f"{'N':>5} {'off ms/f':>9} {'on ms/f':>9} {'self-collide ms/f':>17} {'share':>6}")
    for n in (int(s) for s in args.bake_sizes.split(",")):
        with tempfile.TemporaryDirectory() as tmp:
            off, _ = bake_ms(n, args.frames, False, Path(tmp), args.repeats)
            on, stage = bake_ms(n, args.frames, True, Path(tmp), args.repeats)
        print(f"{n:>5} {off:>9.3f} {on:>9.3f} {stage:>17.3f} {100 * stage / on:>5.1f}%", flush=True)


if __name__ == "__main__":
    main()
