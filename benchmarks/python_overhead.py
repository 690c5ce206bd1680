"""How much of a bake's CPU is Python outside the compiled kernels (issue 11: < 10% on the walk).

    python benchmarks/python_overhead.py [--scene examples/skirt/walk.toml] [--repeats 3] [--profile-stages]

Bakes the scene into ``null`` once to compile (or load) its kernels, then ``--repeats`` more
times while every call from Python into a compiled function is timed: numba's dispatcher
``__call__`` is wrapped so that the CPU (process time, so parallel kernels count in full)
between entering and leaving the outermost compiled call is summed. Calls made from compiled
code to other kernels do not pass through ``__call__`` and are part of their caller's time.
The rest of the simulation's CPU (the bake's CPU minus its JIT warm-up) is Python: frame
planning, track sampling, collider posing, stats and writing. The wrapper's own cost (a
fraction of a microsecond per call) counts as Python, so the share is an upper bound.
Prints the median run's CPU ms per frame, kernel ms per frame, the Python share and the
kernel calls per frame. ``--profile-stages`` bakes with the per-stage profile (the Python
stage loop that ``clothtool bake --profile`` runs).
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from numba.core.registry import CPUDispatcher

from clothtool.bake import BakeOptions, bake
from clothtool.loading import load_scene

REPO = Path(__file__).resolve().parents[1]


class KernelClock:
    """Sums the process time spent inside outermost calls to compiled functions."""

    def __init__(self) -> None:
        self.seconds = 0.0
        self.calls = 0
        self._depth = 0
        self._original = CPUDispatcher.__call__

    def __enter__(self) -> "KernelClock":
        original, clock = self._original, self

        def timed(dispatcher, *args, **kwargs):
            if clock._depth:
                return original(dispatcher, *args, **kwargs)
            clock._depth = 1
            start = time.process_time()
            try:
                return original(dispatcher, *args, **kwargs)
            finally:
                clock.seconds += time.process_time() - start
                clock.calls += 1
                clock._depth = 0

        CPUDispatcher.__call__ = timed
        return self

    def __exit__(self, *exc) -> None:
        CPUDispatcher.__call__ = self._original


def measure(scene, options: BakeOptions) -> dict:
    with KernelClock() as clock:
        stats = bake(scene, "null", options)
    cpu = stats.cpu_s - stats.jit_s
    frames = stats.frames_simulated
    return {
        "cpu_ms": 1000.0 * cpu / frames,
        "kernel_ms": 1000.0 * clock.seconds / frames,
        "python_share": max(cpu - clock.seconds, 0.0) / cpu,
        "calls": clock.calls / frames,
        "iterations": stats.iterations_per_frame,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", type=Path, default=REPO / "examples" / "skirt" / "walk.toml")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--profile-stages", action="store_true", help="bake with the per-stage profile")
    args = parser.parse_args()
    scene = load_scene(args.scene)
    options = BakeOptions(profile_stages=args.profile_stages)
    bake(scene, "null", options)  # compile or load the kernels
    runs = sorted((measure(scene, options) for _ in range(args.repeats)), key=lambda r: r["cpu_ms"])
    median = runs[len(runs) // 2]
    print(f"scene {args.scene.name}: {median['iterations']} iterations per frame, "
          f"{'per-stage profile' if args.profile_stages else 'compiled frame'}")
    print(f"  CPU ms/frame {median['cpu_ms']:.3f} (runs: {', '.join(format(r['cpu_ms'], '.3f') for r in runs)})")
    print(f"  kernel CPU ms/frame {median['kernel_ms']:.3f}; compiled calls per frame {median['calls']:.1f}")
    print(f"  Python outside kernels: {100.0 * median['python_share']:.1f}% of the bake's CPU "
          f"(median {statistics.median(100.0 * r['python_share'] for r in runs):.1f}%)")


if __name__ == "__main__":
    main()
