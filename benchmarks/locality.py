"""Cost per particle-iteration against cloth size, with and without the cook's particle order.

    python benchmarks/locality.py [--sizes 100,316,1000] [--frames 6] [--repeats 3]
                                  [--orders none,rcm,morton] [--meshes scanline,shuffled]

The N x N hanging cloth of ``benchmarks/bake.py`` (1 m across, pinned at its two top
corners, cotton without air drag, production solver at 300 Hz and 60 fps: 5 iterations per
frame) on one thread (NUMBA_NUM_THREADS=1 unless set). Two meshes of each size:

* ``scanline``: ``clothtool.mesh.shapes.grid``'s row-by-row vertex order, already local;
* ``shuffled``: the same grid with its vertices and faces in a random (seeded) order, as a
  garment exported from a DCC may arrive.

Each is cooked three ways: ``none`` (``CookOptions(reorder=False)``: particles in vertex
order), ``rcm`` (the default: reverse Cuthill-McKee, ``clothtool.cook.locality``) and
``morton`` (the mesh put in 3-D Morton order first, then cooked without reordering). The
solver loop runs exactly as ``bake()`` drives it (plan_frame, then iterate), timed in process
CPU time after JIT warm-up; runs of one size are interleaved (A B C A B C) and the median of
the repeats is printed as CPU ns per particle-iteration, with the ratio of the largest size to
the smallest for each mesh and order. Tethers are straight-line (the cook of a 1M-particle
grid with geodesic tethers takes minutes; the solver's tether stage costs the same either way).
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")  # before numba is imported
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import statistics  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from clothtool.bake import make_solvers  # noqa: E402
from clothtool.cook import locality  # noqa: E402
from clothtool.cook.cooker import CookOptions, cook_fabric  # noqa: E402
from clothtool.io.fabric_file import write_fabric  # noqa: E402
from clothtool.loading import load_scene  # noqa: E402
from clothtool.mesh.clothmesh import ClothMesh  # noqa: E402
from clothtool.mesh.shapes import grid  # noqa: E402
from clothtool.profile import StageProfiler  # noqa: E402

SCENE = """
[scene]
fps = 60.0
frames = [0, {frames}]
[solver]
preset = "production"
frequency = 300.0
[output]
attributes = []
[cloth.sheet]
fabric = "sheet.fabric.h5"
material = {{ preset = "cotton", drag_coefficient = 0.0, lift_coefficient = 0.0 }}
"""


def hanging_grid(n: int) -> ClothMesh:
    """The N x N grid 1 m across with a 'pin' attribute at its two top corners."""
    mesh = grid(n, n, 1.0 / (n - 1))
    pin = np.zeros(n * n, np.float32)
    pin[[0, n - 1]] = 1.0
    return mesh.replace(vertex_attrs={"pin": pin})


def shuffled(mesh: ClothMesh, seed: int = 0) -> ClothMesh:
    """``mesh`` with its vertices and its faces in a random order (same surface)."""
    rng = np.random.default_rng(seed)
    mesh = locality.reorder_mesh(mesh, rng.permutation(mesh.vertex_count))
    faces = mesh.face_vertex_indices.reshape(-1, mesh.face_vertex_counts[0])  # grid faces: one size
    corners = mesh.face_vertex_uv.reshape(faces.shape[0], faces.shape[1], 2)
    order = rng.permutation(faces.shape[0])
    return mesh.replace(face_vertex_indices=faces[order].reshape(-1), face_vertex_uv=corners[order].reshape(-1, 2))


def cooked(mesh: ClothMesh, order: str):
    options = CookOptions(pin_attr="pin", tethers="euclidean", reorder=order == "rcm")
    if order == "morton":
        mesh = locality.reorder_mesh(mesh, locality.morton_order(mesh))
    return cook_fabric(mesh, options).fabric


def solver_for(fabric, frames: int, folder: Path):
    folder.mkdir(parents=True, exist_ok=True)
    write_fabric(fabric, folder / "sheet.fabric.h5")
    (folder / "scene.toml").write_text(SCENE.format(frames=frames))
    scene = load_scene(folder / "scene.toml")
    solver = make_solvers(scene, StageProfiler())[0]
    solver.warm_up()
    return scene, solver


def run_frames(scene, solver) -> tuple[float, int]:
    """CPU seconds and particle-iterations of the scene's frames, as bake() drives them."""
    frame_dt = 1.0 / scene.fps
    iterations = 0
    cpu0 = time.process_time()
    for frame in range(scene.start_frame + 1, scene.end_frame + 1):
        plan = solver.plan_frame(frame, scene.frame_time(frame - 1), frame_dt, scene.frame_time(frame))
        for index in range(plan.iterations):
            solver.iterate(solver.iteration(plan, index))
        iterations += plan.iterations
    return time.process_time() - cpu0, iterations * solver.model.particle_count


def measure(n: int, kind: str, orders: list[str], frames: int, repeats: int) -> dict[str, tuple[float, int]]:
    """Median ns per particle-iteration and set count of each order, runs interleaved."""
    mesh = hanging_grid(n)
    if kind == "shuffled":
        mesh = shuffled(mesh)
    with tempfile.TemporaryDirectory() as tmp:
        runs = {}
        for order in orders:
            fabric = cooked(mesh, order)
            runs[order] = (*solver_for(fabric, frames, Path(tmp) / order), [])
        for _ in range(repeats):
            for order in orders:
                scene, solver, times = runs[order]
                cpu, particle_iterations = run_frames(scene, solver)
                times.append(1e9 * cpu / particle_iterations)
        return {order: (statistics.median(times), solver.model.fabric.set_count) for order, (_, solver, times) in runs.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="100,316,1000", help="grid sides N (N x N particles)")
    parser.add_argument("--frames", type=int, default=6)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--orders", default="none,rcm,morton")
    parser.add_argument("--meshes", default="scanline,shuffled")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    orders = args.orders.split(",")
    print(f"CPU ns per particle-iteration, one thread (NUMBA_NUM_THREADS={os.environ['NUMBA_NUM_THREADS']}), "
          f"median of {args.repeats}, {args.frames} frames of 5 iterations")
    print(f"{'N':>5} {'particles':>9} {'mesh':>9} " + " ".join(f"{o:>14}" for o in orders))
    results = {}
    for n in sizes:
        for kind in args.meshes.split(","):
            row = measure(n, kind, orders, args.frames, args.repeats)
            results[n, kind] = row
            cells = " ".join(f"{row[o][0]:>7.1f} ({row[o][1]:>3} s)" for o in orders)
            print(f"{n:>5} {n * n:>9} {kind:>9} {cells}", flush=True)
    if len(sizes) > 1:
        small, large = sizes[0], sizes[-1]
        print(f"ratio {large}^2 / {small}^2:")
        for kind in args.meshes.split(","):
            cells = " ".join(f"{results[large, kind][o][0] / results[small, kind][o][0]:>14.2f}" for o in orders)
            print(f"{'':>5} {'':>9} {kind:>9} {cells}")
    print("(s = conflict-free sets of the fabric)")


if __name__ == "__main__":
    main()
