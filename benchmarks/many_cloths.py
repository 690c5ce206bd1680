"""Many small cloths against one cloth of the same total size (issue 11, item 3: "16 small
cloths cost what one cloth of the same total size costs").

    python benchmarks/many_cloths.py [--frames 100] [--repeats 5] [--precision float64]

Scenes: N x N sheets 1 m across pinned at their two top corners, geodesic tethers, cotton
without air drag, production solver at 300 Hz and 60 fps (5 iterations per frame), side by
side: one 64^2 sheet, 16 sheets of 16^2 and 4 sheets of 32^2 (4096 particles each scene).
Each is baked through ``bake()`` into ``null`` with its default per-frame stats, with the
cloths merged into one solve (clothtool.solver.merge, the default) and solved apart
(``BakeOptions(merge_cloths=False)``). Prints CPU ms per frame after JIT warm-up (process
time), the median of ``--repeats`` interleaved runs, and each row's ratio to the 64^2 sheet
measured in the same run.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
from pathlib import Path

import numpy as np

from clothtool.bake import BakeOptions, bake
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.fabric_file import write_fabric
from clothtool.loading import load_scene
from clothtool.mesh.shapes import grid

ROWS = ((64, 1), (16, 16), (32, 4))  # (sheet size N, sheets)
SCENE = """
[scene]
fps = 60.0
frames = [0, {frames}]
[solver]
preset = "production"
frequency = 300.0
precision = "{precision}"
[output]
attributes = ["stats"]
"""
CLOTH = """
[cloth.sheet{k}]
fabric = "sheet.fabric.h5"
translate = [{x}, 0.0, {z}]
material = {{ preset = "cotton", drag_coefficient = 0.0, lift_coefficient = 0.0, damping = 0.1 }}
"""


def write_scene(folder: Path, n: int, sheets: int, frames: int, precision: str):
    folder.mkdir(parents=True, exist_ok=True)
    pin = np.zeros(n * n, np.float32)
    pin[[0, n - 1]] = 1.0
    mesh = grid(n, n, 1.0 / (n - 1)).replace(vertex_attrs={"pin": pin})
    write_fabric(cook_fabric(mesh, CookOptions(pin_attr="pin", tethers="geodesic")).fabric, folder / "sheet.fabric.h5")
    side = int(np.ceil(np.sqrt(sheets)))
    text = SCENE.format(frames=frames, precision=precision)
    for k in range(sheets):
        text += CLOTH.format(k=k, x=1.2 * (k % side), z=1.2 * (k // side))
    (folder / "scene.toml").write_text(text)
    return load_scene(folder / "scene.toml")


def cpu_ms_per_frame(scene, merge: bool) -> float:
    stats = bake(scene, "null", BakeOptions(merge_cloths=merge))
    return 1000.0 * (stats.cpu_s - stats.jit_s) / stats.frames_simulated


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--precision", choices=("float64", "float32"), default="float64")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as work:
        scenes = {row: write_scene(Path(work) / f"{row[0]}x{row[1]}", *row, args.frames, args.precision) for row in ROWS}
        runs: dict[tuple, list[float]] = {(row, merge): [] for row in ROWS for merge in (True, False)}
        for scene in scenes.values():  # compile (or load) every kernel and frame function first
            for merge in (True, False):
                bake(scene, "null", BakeOptions(merge_cloths=merge))
        for _ in range(args.repeats):  # interleaved: a load change on the machine hits every row alike
            for row, scene in scenes.items():
                for merge in (True, False):
                    runs[row, merge].append(cpu_ms_per_frame(scene, merge))
    median = {key: statistics.median(values) for key, values in runs.items()}
    base = median[ROWS[0], True]
    print(f"many cloths, {args.frames} frames, 5 it/frame, {args.precision}, bake() into null, "
          f"CPU ms per frame (median of {args.repeats})")
    print(f"{'scene':<16}{'merged':>10}{'ratio':>8}{'apart':>10}{'ratio':>8}")
    for n, sheets in ROWS:
        merged, apart = median[(n, sheets), True], median[(n, sheets), False]
        label = f"{sheets} x {n}^2"
        print(f"{label:<16}{merged:>10.3f}{merged / base:>8.2f}{apart:>10.3f}{apart / base:>8.2f}")


if __name__ == "__main__":
    main()
