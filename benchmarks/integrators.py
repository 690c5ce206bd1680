"""Each solver on swinging N x N sheets: ms per frame and error against a converged reference.

    python benchmarks/integrators.py [--sizes 32,64,128] [--frames 24] [--repeats 3]

The sheet (1 m, cotton, undamped, no air drag, pinned along its top edge) is released 60
degrees from hanging and swings for ``frames`` frames at 24 fps. Rows: position-based with
NvCloth stiffness and with XPBD at 300 Hz, implicit at 24 and 96 Hz, explicit at the lowest
frequency its stability limit allows (rounded up to a whole number of substeps). The error is
the RMS particle distance to an XPBD float64 bake at 8 kHz, relative to the sheet's size,
over every 6th frame. Medians of the repeats; 128^2 implicit and explicit take minutes.
"""

from __future__ import annotations

import argparse
import math
import statistics
import tempfile
from pathlib import Path

from clothtool.bake import bake, make_solvers
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.fabric_file import write_fabric
from clothtool.io.memory import MemoryCacheWriter
from clothtool.loading import load_scene
from clothtool.mesh.shapes import grid
from clothtool.profile import StageProfiler
from clothtool.study import position_errors

SCENE = """
[scene]
fps = 24.0
frames = [1, {last}]
[cloth.sheet]
fabric = "sheet.fabric.h5"
material = {{ preset = "cotton", damping = 0.0, drag_coefficient = 0.0, lift_coefficient = 0.0 }}
rotate_euler = [60.0, 0.0, 0.0]
"""


def run(path: Path, overrides: list[str]):
    writer = MemoryCacheWriter(keep_every=6)
    stats = bake(load_scene(path, overrides), writer)
    return writer.frames, 1000.0 * stats.simulation_s / stats.frames_simulated


def explicit_frequency(path: Path) -> float:
    scene = load_scene(path, ['solver.integrator="explicit"', "solver.force=true"])
    limit = make_solvers(scene, StageProfiler())[0].stability["min_frequency_hz"]
    return math.ceil(limit / 24.0) * 24.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="32,64,128")
    parser.add_argument("--frames", type=int, default=24)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print(f"{'N':>4} {'solver':<26} {'Hz':>7} {'ms/frame':>10} {'rms error':>10}")
    for n in (int(s) for s in args.sizes.split(",")):
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            fabric = cook_fabric(grid(n, n, 1.0 / (n - 1)), CookOptions(pin_box=(-1, -1e-4, -1, 2, 1, 1), tethers="none")).fabric
            write_fabric(fabric, folder / "sheet.fabric.h5")
            path = folder / "swing.toml"
            path.write_text(SCENE.format(last=args.frames + 1))
            reference, _ = run(path, ['solver.preset="physical"', "solver.frequency=8064", 'solver.precision="float64"'])
            first = reference[min(reference)][0]
            size = float(((first.max(axis=0) - first.min(axis=0)) ** 2).sum() ** 0.5)
            rows = [
                ("pbd, nvcloth stiffness", 300.0, ['solver.preset="production"']),
                ("pbd, xpbd stiffness", 300.0, ['solver.preset="physical"']),
                ("implicit (Baraff-Witkin)", 24.0, ['solver.preset="implicit"']),
                ("implicit (Baraff-Witkin)", 96.0, ['solver.preset="implicit"']),
                ("explicit (mass-spring)", explicit_frequency(path), ['solver.preset="explicit"']),
            ]
            for name, hz, overrides in rows:
                results = [run(path, overrides + [f"solver.frequency={hz}"]) for _ in range(args.repeats)]
                ms = statistics.median(r[1] for r in results)
                error, _ = position_errors(results[0][0], reference, size)
                print(f"{n:>4} {name:<26} {hz:>7.0f} {ms:>10.2f} {error:>10.2e}", flush=True)


if __name__ == "__main__":
    main()
