"""Speed of the implicit integrator: ms per step for N x N cotton cloths.

    python benchmarks/integrators_implicit.py [--sizes 32,64,128] [--steps 48] [--threads 0]
        [--cg-iterations 200] [--cg-tolerance 1e-6] [--sphere]

Each cloth is 1 m across, lies flat (XZ plane), is pinned at its two corners on one side and
falls under gravity at one step per 24 fps frame (the integrator's reason to exist); with
--sphere it falls onto a sphere collider instead. No output is written. Prints the median ms
per step, the mean CG iterations per step, the worst final relative CG residual and the
stage breakdown in ms per step. JIT compilation is excluded (``warm_up`` runs first).
--threads 0 keeps the solver's own choice (one thread below config.parallel_threshold
particles); a positive value forces that many threads for every size.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from clothtool.collision.colliders import ColliderArrays
from clothtool.fabric import Fabric
from clothtool.integrators.implicit.solver import ImplicitClothSolver
from clothtool.mesh.shapes import grid
from clothtool.mesh.topology import vertex_areas
from clothtool.profile import StageProfiler
from clothtool.settings import Placement, SolverConfig, load_material
from clothtool.solver.environment import Environment
from clothtool.solver.model import build_model


def sheet(n: int) -> Fabric:
    mesh = grid(n, n, 1.0 / (n - 1), plane="XZ")
    pos = mesh.vertex_pos.astype(np.float64)
    area = vertex_areas(pos, mesh.face_vertex_counts, mesh.face_vertex_indices)
    inv_mass = 1.0 / area
    inv_mass[[0, n - 1]] = 0.0
    tris = mesh.face_vertex_indices.reshape(-1, 3).astype(np.int32)
    empty_i, empty_f = np.zeros(0, np.int32), np.zeros(0, np.float32)
    return Fabric(
        rest_pos=mesh.vertex_pos, particle_inv_mass=inv_mass.astype(np.float32), particle_area=area.astype(np.float32),
        particle_max_distance=np.full(n * n, np.inf, np.float32), triangles=tris,
        face_vertex_counts=mesh.face_vertex_counts.astype(np.int32), face_vertex_indices=tris.reshape(-1),
        face_vertex_uv=mesh.face_vertex_uv.astype(np.float32), phase_type=empty_i, phase_set_offsets=np.zeros(1, np.int32),
        set_offsets=np.zeros(1, np.int32), constraint_indices=np.zeros((0, 2), np.int32), constraint_rest_length=empty_f,
        constraint_stiffness=empty_f, tether_anchor=empty_i, tether_rest_length=empty_f,
        virtual_particles=np.zeros((0, 4), np.int32), virtual_particle_weights=np.zeros((0, 3), np.float32),
        virtual_batch_offsets=np.zeros(1, np.int32),
    )


def sphere_below(time: float) -> ColliderArrays:
    one = np.ones(1, np.float32)
    return ColliderArrays(
        sphere_center=np.array([[0.5, -0.5, 0.5]], np.float32), sphere_radius=0.3 * one,
        sphere_margin=0.0 * one, sphere_friction=0.5 * one, sphere_is_collider=np.ones(1, bool),
    )


def run(n: int, steps: int, config: SolverConfig, sphere: bool) -> dict:
    fabric = sheet(n)
    if sphere:  # free corners: the sheet drapes over the sphere
        fabric = fabric.replace(particle_inv_mass=(1.0 / fabric.particle_area).astype(np.float32))
    model = build_model("sheet", fabric, load_material("cotton", "benchmark"), Placement(), 1.0, "Y")
    profiler = StageProfiler()
    environment = Environment(np.array([0.0, -9.81, 0.0]), colliders=sphere_below if sphere else None)
    solver = ImplicitClothSolver(model, config, environment, profiler)
    solver.warm_up()
    dt = 1.0 / 24.0
    times, iterations, residual = [], [], 0.0
    for frame in range(1, steps + 1):
        start = time.perf_counter()
        solver.step(frame, (frame - 1) * dt, dt)
        times.append(time.perf_counter() - start)
        iterations.append(solver.last_cg["iterations"])
        residual = max(residual, solver.last_cg["residual"])
    finite = bool(np.isfinite(solver.state.cur).all())
    speed = float(np.linalg.norm(solver.world_velocities(dt), axis=1).max())
    stages = {name: 1000.0 * profiler.seconds[name] / profiler.calls[name] for name in solver.stage_names}
    return {"n": n, "ms": 1000.0 * statistics.median(times), "cg": float(np.mean(iterations)), "residual": residual,
            "finite": finite, "speed": speed, "stages": stages}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="32,64,128")
    parser.add_argument("--steps", type=int, default=48)
    parser.add_argument("--threads", type=int, default=0)
    parser.add_argument("--cg-iterations", type=int, default=200)
    parser.add_argument("--cg-tolerance", type=float, default=1e-6)
    parser.add_argument("--sphere", action="store_true")
    args = parser.parse_args()
    threshold = 1 if args.threads > 1 else (10**9 if args.threads == 1 else SolverConfig.parallel_threshold)
    if args.threads > 1:
        import numba

        numba.set_num_threads(args.threads)
    config = SolverConfig(frequency=24.0, parallel_threshold=threshold, cg_tolerance=args.cg_tolerance,
                         cg_max_iterations=args.cg_iterations)
    print(f"{'N':>5} {'particles':>9} {'ms/step':>8} {'CG it':>6} {'residual':>9} {'|v|max':>7}  stages (ms/step)")
    for n in (int(s) for s in args.sizes.split(",")):
        r = run(n, args.steps, config, args.sphere)
        stages = ", ".join(f"{k} {v:.2f}" for k, v in r["stages"].items())
        status = "" if r["finite"] else "  NOT FINITE"
        print(f"{n:>5} {n * n:>9} {r['ms']:>8.2f} {r['cg']:>6.0f} {r['residual']:>9.1e} {r['speed']:>7.2f}  {stages}{status}")


if __name__ == "__main__":
    main()
