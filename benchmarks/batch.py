"""Many small bakes: sequential vs ``--jobs 2`` vs a 2-worker Dask cluster on this machine.

    python benchmarks/batch.py [--bakes 16] [--size 32] [--frames 120] [--no-dask]

Writes 4 scenes of an N x N sheet pinned along one edge and bakes each with a wedge over
the solver frequency (``--bakes`` caches in all) through the command line, as a CI job
would run it (process start-up, imports, JIT cache loading and worker start-up included):

    clothtool bake 'shots/*.toml' -o 'caches/{scene}/{wedge}.h5' --wedge solver.frequency=...
        [--jobs 2 | --scheduler local --jobs 2]

Prints per mode: wall time, throughput (bakes per second), the time inside the jobs, and
the overhead per job: worker-seconds not spent inside a job (start-up, scheduling,
transfers), i.e. (wall x workers - time in jobs) / bakes. Checks that every mode wrote
the same bytes.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SCENES = 4
SCENE = """
version = 1
[scene]
name = "shot{index}"
fps = 24.0
frames = [1, {frames}]
[solver]
preset = "preview"
[output]
attributes = []
[cloth.sheet]
fabric = "sheet.fabric.h5"
material = "cotton"
translate = [0.0, {index}.0, 0.0]
"""


def write_shots(folder: Path, size: int, frames: int) -> None:
    from clothtool.cook.cooker import CookOptions, cook_fabric
    from clothtool.io.fabric_file import write_fabric
    from clothtool.mesh.shapes import grid

    folder.mkdir(parents=True)
    fabric = cook_fabric(grid(size, size, 1.0 / (size - 1), plane="XZ"), CookOptions(pin_box=(-1, -1, -1, 0.01, 1, 2))).fabric
    write_fabric(fabric, folder / "sheet.fabric.h5")
    for index in range(SCENES):
        (folder / f"shot{index}.toml").write_text(SCENE.format(index=index, frames=frames))


def run_mode(work: Path, name: str, extra: list[str], frequencies: list[int]) -> dict:
    out = work / name
    command = [sys.executable, "-m", "clothtool", "bake", "shots/*.toml", "-o", f"{name}/{{scene}}/{{wedge}}.h5",
               "--wedge", "solver.frequency=" + ",".join(map(str, frequencies)), "--no-progress", *extra]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    start = time.perf_counter()
    done = subprocess.run(command, cwd=work, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"{name}: the batch failed: {done.stderr.strip().splitlines()[-1]}")
    manifest = json.loads((out / "manifest.json").read_text())
    outputs = {e["id"]: next(iter(e["outputs"].values())) for e in manifest["jobs"]}
    return {"mode": name, "wall_s": wall, "in_jobs_s": manifest["summary"]["wall_s"], "jobs": len(outputs),
            "outputs": outputs}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bakes", type=int, default=16, help="caches in all (a multiple of 4) [16]")
    parser.add_argument("--size", type=int, default=32, help="sheet particles per side [32]")
    parser.add_argument("--frames", type=int, default=120, help="frames per bake [120]")
    parser.add_argument("--no-dask", action="store_true", help="skip the Dask cluster mode")
    args = parser.parse_args()
    if args.bakes % SCENES:
        parser.error(f"--bakes must be a multiple of {SCENES}")
    frequencies = [240 + 60 * i for i in range(args.bakes // SCENES)]
    modes = [("sequential", [], 1), ("jobs2", ["--jobs", "2"], 2)]
    if not args.no_dask:
        modes.append(("dask2", ["--scheduler", "local", "--jobs", "2"], 2))
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        write_shots(work / "shots", args.size, args.frames)
        rows = [(run_mode(work, name, extra, frequencies), workers) for name, extra, workers in modes]
    reference = rows[0][0]["outputs"]
    print(f"{args.bakes} bakes of a {args.size}x{args.size} sheet, {args.frames} frames each, on {os.cpu_count()} cores")
    print(f"{'mode':<12} {'workers':>7} {'wall s':>8} {'bakes/s':>8} {'in jobs s':>10} {'overhead s/job':>15}  same bytes")
    for row, workers in rows:
        overhead = (row["wall_s"] * workers - row["in_jobs_s"]) / row["jobs"]
        same = "yes" if row["outputs"] == reference else "NO"
        print(f"{row['mode']:<12} {workers:>7} {row['wall_s']:>8.2f} {row['jobs'] / row['wall_s']:>8.2f} "
              f"{row['in_jobs_s']:>10.2f} {overhead:>15.3f}  {same}")


if __name__ == "__main__":
    main()
