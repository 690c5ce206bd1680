"""Bake speed for N x N hanging cloths (issue 3's benchmark scene).

    python benchmarks/bake.py [--sizes 32,64,128,255] [--frames 200] [--repeats 3] [--plot FILE]
                              [--precision float64,float32]

Each cloth is 1 m across, pinned at its two top corners, with geodesic tethers, cotton
without air drag (as NvCloth's scene), 300 Hz solver frequency at 60 fps (5 iterations per
frame) and a null output. Prints the
median over the repeats of ms per frame (wall and CPU), particle-iterations per second, and
the stage breakdown of the median run. JIT compilation is excluded (warm-up is timed apart).
``--plot`` writes the CPU time per frame of each size, split by stage, as a bar chart (PNG
or SVG by the suffix), with NvCloth's figure and the goal at 128^2 marked.
``--precision`` bakes each size in each listed state precision (solver.precision), the runs
interleaved so that a shared machine's load falls on all of them alike, and prints each
precision's time relative to the first one's.
The native NvCloth CPU solver's reference figure for 128^2 on this machine class is 1.3 ms
CPU per frame; the goal is within 2x of it.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
from pathlib import Path

from clothtool.bake import bake
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.fabric_file import write_fabric
from clothtool.loading import load_scene
from clothtool.mesh.shapes import grid

NVCLOTH_128_CPU_MS = 1.3  # NvCloth's native CPU solver, 128^2, this machine class

SCENE = """
[scene]
fps = 60.0
frames = [0, {frames}]
[solver]
preset = "production"
frequency = 300.0
precision = "{precision}"
fabric_parallel_threshold = {threshold}
[output]
attributes = []
[cloth.sheet]
fabric = "sheet.fabric.h5"
# NvCloth's benchmark scene has no air drag or lift (its defaults): no wind stage
material = {{ preset = "cotton", drag_coefficient = 0.0, lift_coefficient = 0.0 }}
"""


def scene_for(n: int, frames: int, folder: Path, threshold: int = 20000, precision: str = "float64"):
    folder.mkdir(parents=True, exist_ok=True)
    spacing = 1.0 / (n - 1)
    mesh = grid(n, n, spacing)
    pins = folder / "corners.txt"
    pins.write_text(f"0 {n - 1}\n")
    fabric = cook_fabric(mesh, CookOptions(pin_file=str(pins), tethers="geodesic")).fabric
    write_fabric(fabric, folder / "sheet.fabric.h5")
    path = folder / "scene.toml"
    path.write_text(SCENE.format(frames=frames, threshold=threshold, precision=precision))
    return load_scene(path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="32,64,128,255")
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--fabric-parallel-threshold", type=int, default=20000,
                        help="sets of at least this many constraints use all cores (solver.fabric_parallel_threshold)")
    parser.add_argument("--plot", type=Path, help="write the stage breakdown chart here (.png or .svg)")
    parser.add_argument("--precision", default="float64",
                        help="comma-separated state precisions to compare (solver.precision), e.g. float64,float32")
    args = parser.parse_args()
    precisions = args.precision.split(",")
    rows = []
    print(f"{'N':>5} {'particles':>9} {'precision':>9} {'ms/frame':>9} {'cpu ms/f':>9} {'Mpart-it/s':>10} {'cpu ratio':>9}"
          "  stages (ms/frame)")
    for n in (int(s) for s in args.sizes.split(",")):
        with tempfile.TemporaryDirectory() as tmp:
            scenes = {p: scene_for(n, args.frames, Path(tmp) / p, args.fabric_parallel_threshold, p) for p in precisions}
            runs = {p: [] for p in precisions}
            for _ in range(args.repeats):  # interleaved: a load spike hits every precision alike
                for precision in precisions:
                    runs[precision].append(bake(scenes[precision], "null"))
        first_cpu = None
        for precision in precisions:
            ordered = sorted(runs[precision], key=lambda r: r.simulation_s)
            median = ordered[len(ordered) // 2]
            report = median.to_dict()
            frames = median.frames_simulated
            wall_ms = 1000 * statistics.median(r.simulation_s for r in ordered) / frames
            cpu_ms = 1000 * statistics.median(r.cpu_s - r.jit_s for r in ordered) / frames
            first_cpu = cpu_ms if first_cpu is None else first_cpu
            rate = report["timing"]["particle_iterations_per_second"] / 1e6
            stages = " ".join(
                f"{row['stage']}={row['per_frame_ms']:.3f}" for row in report["profile"] if row["stage"] != "jit warm-up"
            )
            print(f"{n:>5} {n * n:>9} {precision:>9} {wall_ms:>9.3f} {cpu_ms:>9.3f} {rate:>10.2f} "
                  f"{cpu_ms / first_cpu:>9.3f}  {stages}", flush=True)
            if precision == precisions[0]:
                rows.append((n, cpu_ms, {row["stage"]: row["per_frame_ms"] for row in report["profile"]
                                         if row["stage"] != "jit warm-up"}))
    if args.plot:
        plot(rows, args.plot)


def plot(rows, path: Path) -> None:
    """Left: CPU ms per frame against particles (log-log) with NvCloth's figure and the goal at
    128^2; right: each stage's share of the frame per size."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (speed, shares) = plt.subplots(1, 2, figsize=(10, 4))
    particles = [n * n for n, _, _ in rows]
    speed.loglog(particles, [cpu for _, cpu, _ in rows], "o-", label="clothtool (CPU)")
    speed.loglog([128 * 128], [NVCLOTH_128_CPU_MS], "k*", markersize=10, label="NvCloth native, 128^2")
    speed.loglog([128 * 128], [2 * NVCLOTH_128_CPU_MS], "r_", markersize=14, mew=2, label="goal: 2x NvCloth")
    speed.set_xlabel("particles")
    speed.set_ylabel("CPU ms per frame")
    speed.legend(fontsize=8)
    speed.grid(True, which="both", alpha=0.3)
    stages = sorted({stage for _, _, split in rows for stage in split}, key=lambda st: -max(r[2].get(st, 0.0) for r in rows))
    labels = [f"{n}^2" for n, _, _ in rows]
    bottom = [0.0] * len(rows)
    for stage in stages:
        share = [100.0 * split.get(stage, 0.0) / sum(split.values()) for _, _, split in rows]
        shares.bar(labels, share, bottom=bottom, label=stage)
        bottom = [b + h for b, h in zip(bottom, share)]
    shares.set_ylabel("% of the frame's stage time")
    shares.legend(fontsize=8, loc="lower right")
    figure.suptitle("clothtool bake: N x N hanging cloth, 300 Hz, 60 fps, null output (median run)")
    figure.tight_layout()
    figure.savefig(path, metadata={"Date": None} if path.suffix == ".svg" else {"Software": None})
    plt.close(figure)


if __name__ == "__main__":
    main()
