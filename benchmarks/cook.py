"""Cook time for grids and the bundled garment, with geodesic and euclidean tethers.

    python benchmarks/cook.py [--repeats 3] [--sizes 64,256,1024]

Prints one row per (mesh, tether mode): median wall time of the cook (mesh checks, welding,
adjacency, phases, scheduling, tethers, validation) and of writing the fabric file, plus the
step breakdown of the median run. Grids hang from their pinned top row. Goals (issue 2):
256^2 under 1.5 s, 1024^2 under 20 s with geodesic tethers.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.fabric_file import write_fabric
from clothtool.io.meshin import read_mesh
from clothtool.mesh.shapes import grid

REPO = Path(__file__).resolve().parent.parent


def cases(sizes):
    for n in sizes:
        spacing = 1.0 / (n - 1)
        yield f"grid {n}x{n}", grid(n, n, spacing), dict(pin_box=(-1, -0.5 * spacing, -1, 2, 1, 1))
    yield "skirt (examples)", read_mesh(REPO / "examples/skirt/skirt.usda"), dict(pin_attr="pin")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--sizes", default="64,256,1024")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    # compile the numba kernels once so no row pays for it
    cook_fabric(grid(4, 4, 0.1), CookOptions(pin_box=(-1, -0.01, -1, 1, 1, 1)))

    print(f"{'mesh':<18} {'tethers':<10} {'particles':>9} {'constraints':>11} {'cook s':>8} {'write s':>8}  breakdown (s)")
    with tempfile.TemporaryDirectory() as tmp:
        for name, mesh, pins in cases(sizes):
            for mode in ("geodesic", "euclidean"):
                runs = []
                for _ in range(args.repeats):
                    start = time.perf_counter()
                    result = cook_fabric(mesh, CookOptions(tethers=mode, **pins))
                    cooked = time.perf_counter()
                    write_fabric(result.fabric, Path(tmp) / "bench.fabric.h5")
                    runs.append((cooked - start, time.perf_counter() - cooked, result))
                runs.sort(key=lambda r: r[0])
                cook_s, _, result = runs[len(runs) // 2]
                write_s = statistics.median(r[1] for r in runs)
                steps = " ".join(f"{k}={v:.2f}" for k, v in result.seconds.items())
                print(
                    f"{name:<18} {mode:<10} {result.fabric.particle_count:>9} {result.fabric.constraint_count:>11} "
                    f"{cook_s:>8.3f} {write_s:>8.3f}  {steps}",
                    flush=True,
                )


if __name__ == "__main__":
    main()
