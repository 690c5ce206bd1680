"""Hard cases over solver settings: which settings fail, and how.

    python benchmarks/accuracy/hard_cases.py [--frequencies 24,60,120,300,600] [--modes nvcloth,xpbd]
                                             [--fps 24] [--cases NAME,...]

Runs every hard case of tests/physics/test_hard_*.py (the scenes and pass criteria are
defined there; the tests assert them at the settings they name) at each solver frequency and
stiffness mode, at --fps frames per second (24 by default, so "24 Hz" is one iteration per
frame; the iterations per frame are round(frequency / fps)), and prints one row per run:
case, setting, pass/fail, and how it failed (NaN at frame, max speed, strain, penetration,
energy) or what it measured; then a pass/fail matrix.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests.physics

from tests.physics.test_hard_bad_start import bad_start_run, judge as judge_bad_start  # noqa: E402
from tests.physics.test_hard_collision import (  # noqa: E402
    SELF_DISTANCE,
    THICKNESS,
    curtain,
    judge_sweep,
    squeeze_run,
    sweep_run,
    twist_run,
)
from tests.physics.test_hard_degenerate_input import degenerate_run  # noqa: E402
from tests.physics.test_hard_heavy_bob import SPEED_LIMIT as BOB_SPEED, heavy_bob_run  # noqa: E402
from tests.physics.test_hard_jitter import SPEED_LIMIT as JITTER_SPEED, jitter_run  # noqa: E402


def twist_failures(run):
    failures = run.failures(5.0)
    if run.notes["_closest"] < 0.5 * SELF_DISTANCE:
        failures.append(f"particles {run.notes['closest']} apart (< {SELF_DISTANCE * 500:g} mm)")
    return failures


def jitter_failures(run):
    failures = run.failures(JITTER_SPEED, strain_target=0.15)
    if run.final_strain >= 0.01:
        failures.append(f"strain {run.final_strain:.2%} after 3 s")
    return failures


def cases(fps: float):
    """name -> (run(frequency, mode) -> HardCaseRun, judge(run) -> failures)."""
    sheet = curtain()
    table = {
        "bob 100x, tethers": (lambda f, m: heavy_bob_run(100, f, m, tethers=True, fps=fps), lambda r: r.failures(BOB_SPEED, 0.05)),
        "bob 1000x, tethers": (lambda f, m: heavy_bob_run(1000, f, m, tethers=True, fps=fps), lambda r: r.failures(BOB_SPEED, 0.05)),
        "bob 1000x, no tethers": (lambda f, m: heavy_bob_run(1000, f, m, fps=fps), lambda r: r.failures(BOB_SPEED, 0.05)),
        "leather, jittered frames": (lambda f, m: jitter_run(f, m, fps=24.0)[0], jitter_failures),
        "double size": (lambda f, m: bad_start_run("double", f, m, fps=fps), judge_bad_start),
        "scrambled": (lambda f, m: bad_start_run("scrambled", f, m, fps=fps), judge_bad_start),
        "scrambled, seed 3": (lambda f, m: bad_start_run("scrambled", f, m, seed=3, fps=fps), judge_bad_start),
        "degenerate: micro-edge": (lambda f, m: degenerate_run("micro-edge", f, m, fps=fps), lambda r: r.failures(10.0)),
        "degenerate: unwelded": (lambda f, m: degenerate_run("coincident-vertices-unwelded", f, m, fps=fps), lambda r: r.failures(10.0)),
    }
    for speed in (10.0, 20.0, 30.0):
        table[f"capsule sweep {speed:g} m/s"] = (
            lambda f, m, speed=speed: sweep_run(speed, f, m, fps=fps, fabric=sheet),
            lambda r, speed=speed: judge_sweep(r, speed),
        )
    table["squeeze"] = (lambda f, m: squeeze_run(f, m, fps=fps), lambda r: r.failures(10.0, penetration_limit=THICKNESS))
    table["squeeze, self-collision"] = (
        lambda f, m: squeeze_run(f, m, self_collision=True, fps=fps),
        lambda r: r.failures(10.0, penetration_limit=THICKNESS),
    )
    table["twist, self-collision"] = (lambda f, m: twist_run(f, m, fps=fps), twist_failures)
    return table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frequencies", default="24,60,120,300,600")
    parser.add_argument("--modes", default="nvcloth,xpbd")
    parser.add_argument("--fps", type=float, default=24.0)
    parser.add_argument("--cases", default="", help="comma-separated case names (default: all)")
    args = parser.parse_args()
    table = cases(args.fps)
    chosen = [c.strip() for c in args.cases.split(",") if c.strip()] or list(table)
    frequencies = [float(f) for f in args.frequencies.split(",")]
    modes = args.modes.split(",")
    print(f"{'case':<26} {'setting':<22} {'result':<6} how")
    failed = 0
    verdicts: dict[tuple[str, str], list[str]] = {}
    start = time.perf_counter()
    for name in chosen:
        run, judge = table[name]
        for mode in modes:
            for frequency in frequencies:
                iterations = max(1, int(frequency / args.fps + 0.5))
                setting = f"{mode} {frequency:g} Hz ({iterations} it/f)"
                result = run(frequency, mode)
                failures = judge(result)
                failed += bool(failures)
                how = "; ".join(failures) if failures else result.summary()
                if failures:
                    how += f"  [{result.summary()}]"
                print(f"{name:<26} {setting:<22} {'FAIL' if failures else 'pass':<6} {how}", flush=True)
                verdicts.setdefault((name, mode), []).append("FAIL" if failures else "pass")
    print(f"{failed} failing runs; {time.perf_counter() - start:.0f} s")
    print()
    print(f"{'case':<26} {'mode':<8} " + " ".join(f"{f:>6g}" for f in frequencies) + "  (solver frequency, Hz)")
    for (name, mode), cells in verdicts.items():
        print(f"{name:<26} {mode:<8} " + " ".join(f"{c:>6}" for c in cells))


if __name__ == "__main__":
    main()
