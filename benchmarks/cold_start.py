"""Cold start of the README's walk bake: CPU seconds spent compiling kernels with an empty
kernel cache (a fresh install or CI machine).

    python benchmarks/cold_start.py [--max-cpu 5]

Runs, in a child process with a new empty CLOTHTOOL_CACHE_DIR, the README's cook (which
compiles the cook kernels into the cache, as the README's first command does) and then the
walk scene's solver and meter warm-ups exactly as ``clothtool bake ... --report`` runs them
and its first frame (which compiles the scene's frame function, clothtool.solver.framefn),
timing their CPU (process time) and wall. A second run with the cache now filled
shows what a warm start costs. ``--max-cpu`` exits 1 when the cold compile CPU exceeds it
(.ci/run uses this as the cold-start check).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

CHILD = """
import json, sys, time
from clothtool.bake import make_solvers, simulate_frame
from clothtool.profile import StageProfiler
from clothtool.loading import load_scene
from clothtool.solver.measure import ClothMeter

scene = load_scene(sys.argv[1])  # cooks the skirt on the fly: compiles (or loads) the cook kernels
solvers = make_solvers(scene, StageProfiler())
meters = [ClothMeter(solver) for solver in solvers]
cpu0, wall0 = time.process_time(), time.perf_counter()
for solver, meter in zip(solvers, meters):
    solver.warm_up()
    meter.warm_up(True)  # --report computes percentiles
cpu1, wall1 = time.process_time(), time.perf_counter()
# the first frame compiles (or loads) the scene's frame function, as the bake's first frame does
frame, dt = scene.start_frame + 1, 1.0 / scene.fps
plans = [s.plan_frame(frame, scene.frame_time(frame - 1), dt, scene.frame_time(frame)) for s in solvers]
simulate_frame(solvers, plans, True)
cpu2, wall2 = time.process_time(), time.perf_counter()
print(json.dumps({"cpu_s": cpu2 - cpu0, "wall_s": wall2 - wall0, "kernels_cpu_s": cpu1 - cpu0,
                  "frame_cpu_s": cpu2 - cpu1}))
"""


def warm_up(cache: Path) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("CLOTHTOOL_")}
    env["CLOTHTOOL_CACHE_DIR"] = str(cache)
    result = subprocess.run(
        [sys.executable, "-c", CHILD, str(REPO / "examples" / "skirt" / "walk.toml")],
        env=env, capture_output=True, text=True, check=True,
    )
    return json.loads(result.stdout.splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--max-cpu", type=float, help="fail (exit 1) when the cold compile takes more CPU seconds")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="clothtool-cold-") as tmp:
        cache = Path(tmp) / "cache"
        cold = warm_up(cache)
        warm = warm_up(cache)
    for name, run in (("empty", cold), ("filled", warm)):
        print(f"walk bake JIT warm-up, {name} kernel cache: {run['cpu_s']:.2f} s CPU ({run['wall_s']:.2f} s wall): "
              f"stage and stats kernels {run['kernels_cpu_s']:.2f} s, the first frame with its frame function "
              f"{run['frame_cpu_s']:.2f} s")
    if args.max_cpu is not None and cold["cpu_s"] > args.max_cpu:
        print(f"cold start compiles for {cold['cpu_s']:.2f} s CPU, over the limit of {args.max_cpu:g} s", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
