"""Speed of the explicit (mass-spring) integrator: ms per substep for N x N hanging cloths.

    python benchmarks/integrators_explicit.py [--sizes 32,64,128] [--substeps 400] [--repeats 3]

Each cloth is 1 m across, cotton, pinned at its two top corners, falling past a sphere and
a ground plane, with a 3 m/s wind; the solver runs at the cloth's stability limit (the
lowest frequency the explicit solver accepts). Prints the median over the repeats of ms per
substep (all stages, and per stage), the stability figures, and what a 24 fps frame costs
at that frequency: the reason the position-based and implicit integrators exist.
JIT compilation is excluded (warm-up runs first); nothing is written.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from clothtool.collision.colliders import ColliderArrays
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.integrators.explicit import ExplicitClothSolver
from clothtool.mesh.shapes import grid
from clothtool.profile import StageProfiler
from clothtool.settings import Placement, SolverConfig, load_material
from clothtool.solver.environment import Environment
from clothtool.solver.model import build_model

FPS = 24.0


def colliders() -> ColliderArrays:
    f32 = lambda x: np.asarray(x, np.float32)  # noqa: E731
    return ColliderArrays(
        sphere_center=f32([[0.5, -0.7, 0.1]]), sphere_radius=f32([0.2]), sphere_margin=f32([0.005]),
        sphere_friction=f32([0.5]), sphere_is_collider=np.array([True]),
        plane=f32([[0.0, 1.0, 0.0, -1.2]]), convex_plane_offsets=np.array([0, 1], np.int32),
        convex_margin=f32([0.0]), convex_friction=f32([0.5]),
    )


def solver_for(n: int) -> ExplicitClothSolver:
    mesh = grid(n, n, 1.0 / (n - 1))
    fabric = cook_fabric(mesh, CookOptions(tethers="none")).fabric
    inv_mass = fabric.particle_inv_mass.copy()
    inv_mass[[0, n - 1]] = 0.0
    fabric = fabric.replace(particle_inv_mass=inv_mass)
    model = build_model("sheet", fabric, load_material("cotton", "bench"), Placement(), 1.0, "Y")
    scene = colliders()
    environment = Environment(np.array([0.0, -9.81, 0.0]), lambda t: np.array([0.0, 0.0, 3.0]), 1.2, lambda t: scene)
    probe = ExplicitClothSolver(model, SolverConfig(), environment, StageProfiler())
    # the lowest frequency whose rounded substep count per frame satisfies the limit
    frequency = math.ceil(1.0 / (FPS * probe.stability["h_max_s"])) * FPS
    return ExplicitClothSolver(model, SolverConfig(frequency=frequency), environment, StageProfiler())


def run(n: int, substeps: int) -> tuple[float, dict, ExplicitClothSolver]:
    solver = solver_for(n)
    solver.warm_up()
    plan = solver.plan_frame(1, 0.0, 1.0 / FPS)
    for index in range(min(20, plan.iterations)):  # settle caches
        solver.iterate(solver.iteration(plan, index))
    solver.profiler = StageProfiler()
    start = time.perf_counter()
    for step in range(substeps):
        solver.iterate(solver.iteration(plan, step % plan.iterations))
    wall = time.perf_counter() - start
    per_stage = {name: 1000.0 * s / substeps for name, s in solver.profiler.seconds.items()}
    return 1000.0 * wall / substeps, per_stage, solver


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="32,64,128")
    parser.add_argument("--substeps", type=int, default=400)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print(f"{'N':>5} {'particles':>9} {'springs':>8} {'ms/substep':>10} {'h_max us':>9} {'min Hz':>9} "
          f"{'substeps/frame':>14} {'s/frame@24':>10}  stages (ms/substep)")
    for n in (int(s) for s in args.sizes.split(",")):
        runs = [run(n, args.substeps) for _ in range(args.repeats)]
        runs.sort(key=lambda r: r[0])
        ms, stages, solver = runs[len(runs) // 2]
        h_max = solver.stability["h_max_s"]
        per_frame = math.ceil(1.0 / (FPS * h_max))
        breakdown = "  ".join(f"{k} {v:.3f}" for k, v in stages.items())
        print(
            f"{n:>5} {solver.model.particle_count:>9} {solver.model.constraint_indices.shape[0]:>8} {ms:>10.3f} "
            f"{1e6 * h_max:>9.2f} {1.0 / h_max:>9.0f} {per_frame:>14} {ms * per_frame / 1000.0:>10.2f}  {breakdown}"
        )
    print(f"median of {args.repeats} runs of {args.substeps} substeps; cotton (stretch modulus 20000 N/m, 0.15 kg/m^2)")


if __name__ == "__main__":
    main()
