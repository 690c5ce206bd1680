"""Bake speed for N x N hanging cloths (issue 3's benchmark scene).

    python benchmarks/bake.py [--sizes 32,64,128,255] [--frames 200] [--repeats 3]

Each cloth is 1 m across, pinned at its two top corners, with geodesic tethers, cotton
without air drag (as NvCloth's scene), 300 Hz solver frequency at 60 fps (5 iterations per
frame) and a null output. Prints the
median over the repeats of ms per frame (wall and CPU), particle-iterations per second, and
the stage breakdown of the median run. JIT compilation is excluded (warm-up is timed apart).
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
from clothtool.mesh.shapes import grid
from clothtool.scene.scene import load_scene

SCENE = """
[scene]
fps = 60.0
frames = [0, {frames}]
[solver]
preset = "production"
frequency = 300.0
fabric_parallel_threshold = {threshold}
[output]
attributes = []
[cloth.sheet]
fabric = "sheet.fabric.h5"
# NvCloth's benchmark scene has no air drag or lift (its defaults): no wind stage
material = {{ preset = "cotton", drag_coefficient = 0.0, lift_coefficient = 0.0 }}
"""


def scene_for(n: int, frames: int, folder: Path, threshold: int = 20000):
    spacing = 1.0 / (n - 1)
    mesh = grid(n, n, spacing)
    pins = folder / "corners.txt"
    pins.write_text(f"0 {n - 1}\n")
    fabric = cook_fabric(mesh, CookOptions(pin_file=str(pins), tethers="geodesic")).fabric
    write_fabric(fabric, folder / "sheet.fabric.h5")
    path = folder / "scene.toml"
    path.write_text(SCENE.format(frames=frames, threshold=threshold))
    return load_scene(path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="32,64,128,255")
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--fabric-parallel-threshold", type=int, default=20000,
                        help="sets of at least this many constraints use all cores (solver.fabric_parallel_threshold)")
    args = parser.parse_args()
    print(f"{'N':>5} {'particles':>9} {'ms/frame':>9} {'cpu ms/f':>9} {'Mpart-it/s':>10}  stages (ms/frame)")
    for n in (int(s) for s in args.sizes.split(",")):
        with tempfile.TemporaryDirectory() as tmp:
            scene = scene_for(n, args.frames, Path(tmp), args.fabric_parallel_threshold)
            runs = [bake(scene, "null") for _ in range(args.repeats)]
        runs.sort(key=lambda r: r.simulation_s)
        median = runs[len(runs) // 2]
        report = median.to_dict()
        frames = median.frames_simulated
        wall_ms = 1000 * statistics.median(r.simulation_s for r in runs) / frames
        cpu_ms = 1000 * statistics.median(r.cpu_s - r.jit_s for r in runs) / frames
        rate = report["timing"]["particle_iterations_per_second"] / 1e6
        stages = " ".join(
            f"{row['stage']}={row['per_frame_ms']:.3f}" for row in report["profile"] if row["stage"] != "jit warm-up"
        )
        print(f"{n:>5} {n * n:>9} {wall_ms:>9.3f} {cpu_ms:>9.3f} {rate:>10.2f}  {stages}", flush=True)


if __name__ == "__main__":
    main()
