"""Cache write speed: ms per frame, MB written and peak memory for every cache format.

Each measurement runs in a fresh subprocess (so peak RSS belongs to that run alone) and the
table shows the median of ``--runs`` runs. Frames carry points and velocities of a waving
grid, different every frame (crate files de-duplicate identical arrays).

    python benchmarks/cache_write.py                       # 10k and 100k points, 200 frames
    python benchmarks/cache_write.py --points 100000 --frames 500 --runs 3

``--bake N[,N...]`` instead bakes benchmarks/bake.py's N x N hanging cloth (with the default
output attributes: points and velocities) into each format and prints the CPU ms per frame
of the whole bake (simulation, stats and write, JIT excluded; ``sys``: the part spent in the
kernel, mostly file writes), the file's size, and what each format adds to the ``null``
output's figure:

    python benchmarks/cache_write.py --bake 64,128 --frames 200 --runs 3
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

# name -> (suffix, CacheOptions keyword arguments)
CONFIGS = {
    "h5-gzip": (".h5", {"compression": "gzip"}),
    "h5-lzf": (".h5", {"compression": "lzf"}),
    "h5-none": (".h5", {"compression": "none"}),
    "usdc": (".usdc", {"save_every": 10}),
    "usdc-nosave": (".usdc", {"save_every": 0}),
    "usda": (".usda", {}),
    "null": ("null", {}),
}


def _status_mb(key: str) -> float:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith(key + ":"):
                return int(line.split()[1]) / 1024
    return float("nan")


def grid_cloth(points: int):
    """A square grid of about ``points`` vertices: rest pose, quads and a wave to animate it."""
    from clothtool.io.cache import ClothTopology

    side = max(2, int(round(points**0.5)))
    x, z = np.meshgrid(np.linspace(0, 1, side, dtype=np.float32), np.linspace(0, 1, side, dtype=np.float32))
    rest = np.stack([x.ravel(), np.zeros(side * side, np.float32), z.ravel()], axis=1)
    ids = np.arange(side * side, dtype=np.int32).reshape(side, side)
    quads = np.stack([ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]], axis=-1).reshape(-1, 4)
    cloth = ClothTopology("cloth", rest, np.full(len(quads), 4, np.int32), quads.ravel().copy())
    wave = np.stack([np.zeros_like(x), np.sin(6 * x) * np.cos(4 * z), np.zeros_like(x)], axis=-1).reshape(-1, 3)
    return cloth, wave.astype(np.float32)


def run_one(config: str, points: int, frames: int, out_dir: Path) -> dict:
    """Bake ``frames`` synthetic frames into one cache; time write_frame only."""
    from clothtool.io.cache import CacheHeader, CacheOptions, FrameData, open_cache_writer

    suffix, options = CONFIGS[config]
    cloth, wave = grid_cloth(points)
    header = CacheHeader(24.0, 1, frames, 0.01, "Y", (cloth,), attributes=frozenset({"velocities"}))
    path = "null" if suffix == "null" else out_dir / f"bench{suffix}"
    velocities = np.zeros_like(cloth.rest_pos)
    elapsed = 0.0
    with open_cache_writer(path, CacheOptions(**options)) as writer:
        writer.write_header(header)
        base_rss = _status_mb("VmRSS")
        growth = []
        for f in range(1, frames + 1):
            moved = cloth.rest_pos + np.float32(0.01 * f) * wave
            velocities[:] = np.float32(0.24 + 1e-4 * f) * wave
            frame = FrameData(f, (moved,), (velocities,))
            start = time.perf_counter()
            writer.write_frame(frame)
            elapsed += time.perf_counter() - start
            if f % max(1, frames // 20) == 0:
                growth.append(_status_mb("VmRSS") - base_rss)
        end_rss = _status_mb("VmRSS")
        start = time.perf_counter()
        writer.commit()
        commit_s = time.perf_counter() - start
    size = 0 if suffix == "null" else Path(path).stat().st_size
    return {
        "config": config,
        "points": cloth.particle_count,
        "frames": frames,
        "raw_mb": 2 * cloth.particle_count * 12 * frames / 1e6,
        "file_mb": size / 1e6,
        "ms_per_frame": 1e3 * elapsed / frames,
        "commit_s": commit_s,
        "rss_growth_mb": end_rss - base_rss,
        "rss_growth_trace": [round(g, 1) for g in growth],
        "peak_rss_mb": _status_mb("VmHWM"),
    }


def bake_one(config: str, n: int, frames: int, out_dir: Path) -> dict:
    """Bake the N x N hanging cloth into one cache; CPU time of the frames (every thread) and wall time."""
    sys.path.insert(0, str(REPO / "benchmarks"))
    from bake import scene_for

    from clothtool.bake import BakeOptions, bake
    from clothtool.loading import load_scene

    suffix, options = CONFIGS[config]
    scene_for(n, frames, out_dir)  # writes the fabric and scene.toml
    toml = out_dir / "scene.toml"
    toml.write_text(toml.read_text().replace("attributes = []", 'attributes = ["velocities"]'))
    path = "null" if suffix == "null" else out_dir / f"bench{suffix}"
    clock = {}

    def at_frame(done: int, total: int) -> None:
        if done == 2:  # timed from the end of the second frame: set-up and JIT warm-up excluded
            clock["cpu"], clock["wall"], clock["sys"] = time.process_time(), time.perf_counter(), os.times().system

    bake_options = BakeOptions(compression=options.get("compression"), save_every=options.get("save_every"), progress=at_frame)
    stats = bake(load_scene(toml), path, bake_options)
    cpu, wall = time.process_time() - clock["cpu"], time.perf_counter() - clock["wall"]  # commit included
    system = os.times().system - clock["sys"]  # the kernel's share of cpu (file writes), 10 ms ticks
    timed = stats.frames_simulated - 1
    return {
        "config": config, "n": n, "frames": timed, "cpu_ms_per_frame": 1e3 * cpu / timed,
        "sys_ms_per_frame": 1e3 * system / timed, "wall_ms_per_frame": 1e3 * wall / timed,
        "file_mb": 0 if suffix == "null" else Path(path).stat().st_size / 1e6,
    }


def measure_bakes(n: int, frames: int, runs: int, configs: list[str]) -> list[dict]:
    """Median over ``runs`` fresh processes of each format, runs interleaved (the machine's
    load drifts); ``added`` is the CPU ms per frame over the ``null`` output."""
    results = {config: [] for config in configs}
    for _ in range(runs):
        for config in configs:
            with tempfile.TemporaryDirectory(prefix="clothtool-bench-") as tmp:
                out = subprocess.run(
                    [sys.executable, __file__, "--one-bake", config, "--bake", str(n), "--frames", str(frames), "--dir", tmp],
                    check=True, capture_output=True, text=True,
                ).stdout
            results[config].append(json.loads(out))
    rows = []
    for config in configs:
        keys = ("cpu_ms_per_frame", "sys_ms_per_frame", "wall_ms_per_frame")
        rows.append({**results[config][0], **{k: statistics.median(r[k] for r in results[config]) for k in keys}})
    null = next((r["cpu_ms_per_frame"] for r in rows if r["config"] == "null"), None)
    for row in rows:
        row["added"] = None if null is None else row["cpu_ms_per_frame"] - null
        row["added_pct"] = None if null is None else 100 * row["added"] / null
    return rows


def print_bake_table(rows: list[dict]) -> None:
    print(f"{'format':<12} {'N':>5} {'frames':>6} {'cpu ms/f':>9} {'sys ms/f':>9} {'wall ms/f':>9} {'MB':>7} {'added ms/f':>10} {'added %':>8}")
    for r in rows:
        added = "" if r["added"] is None else f"{r['added']:>10.3f} {r['added_pct']:>7.1f}%"
        print(
            f"{r['config']:<12} {r['n']:>5} {r['frames']:>6} {r['cpu_ms_per_frame']:>9.3f} {r['sys_ms_per_frame']:>9.3f} "
            f"{r['wall_ms_per_frame']:>9.3f} {r['file_mb']:>7.1f} {added}"
        )


def measure(config: str, points: int, frames: int, runs: int) -> dict:
    """Median over ``runs`` fresh processes."""
    results = []
    for _ in range(runs):
        with tempfile.TemporaryDirectory(prefix="clothtool-bench-") as tmp:
            out = subprocess.run(
                [sys.executable, __file__, "--one", config, "--points", str(points), "--frames", str(frames), "--dir", tmp],
                check=True, capture_output=True, text=True,
            ).stdout
        results.append(json.loads(out))
    median = {k: statistics.median(r[k] for r in results) for k in ("file_mb", "ms_per_frame", "commit_s", "rss_growth_mb", "peak_rss_mb")}
    return {**results[0], **median}


def print_table(rows: list[dict]) -> None:
    print(f"{'format':<12} {'points':>8} {'frames':>6} {'raw MB':>8} {'MB written':>10} {'ms/frame':>9} {'commit s':>8} {'RSS growth MB':>13} {'peak RSS MB':>11}")
    for r in rows:
        print(
            f"{r['config']:<12} {r['points']:>8} {r['frames']:>6} {r['raw_mb']:>8.0f} {r['file_mb']:>10.0f} "
            f"{r['ms_per_frame']:>9.2f} {r['commit_s']:>8.2f} {r['rss_growth_mb']:>13.0f} {r['peak_rss_mb']:>11.0f}"
        )


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--points", type=int, nargs="+", default=[10_000, 100_000])
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--formats", nargs="+", default=["null", "h5-gzip", "h5-lzf", "h5-none", "usdc", "usda"], choices=list(CONFIGS))
    parser.add_argument("--bake", help="N[,N...]: bake the N x N hanging cloth into each format instead")
    parser.add_argument("--one", choices=list(CONFIGS), help=argparse.SUPPRESS)
    parser.add_argument("--one-bake", choices=list(CONFIGS), help=argparse.SUPPRESS)
    parser.add_argument("--dir", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one_bake:
        print(json.dumps(bake_one(args.one_bake, int(args.bake), args.frames, Path(args.dir))))
        return
    if args.bake:
        for n in (int(size) for size in args.bake.split(",")):
            print_bake_table(measure_bakes(n, args.frames, args.runs, args.formats))
        return
    if args.one:
        print(json.dumps(run_one(args.one, args.points[0], args.frames, Path(args.dir))))
        return
    rows = [measure(config, points, args.frames, args.runs) for points in args.points for config in args.formats]
    print_table(rows)


if __name__ == "__main__":
    main()
