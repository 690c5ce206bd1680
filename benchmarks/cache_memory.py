"""Does memory stay flat while a long bake streams into a cache?

Bakes ``--frames`` synthetic frames of a ``--points`` cloth (points + velocities) into each
format, each run in a fresh process, and prints the growth of the resident set size from the
first frame to the last (median of ``--runs``) next to the raw size of the data. "usdc-nosave"
is the USD writer with periodic saves switched off (``save_every=0``): the control that shows
what the periodic saves buy.

    python benchmarks/cache_memory.py                      # 100k points, 2000 frames, 3 runs
    python benchmarks/cache_memory.py --frames 500 --runs 1 --formats usdc usdc-nosave
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cache_write import CONFIGS, measure  # noqa: E402


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--points", type=int, default=100_000)
    parser.add_argument("--frames", type=int, default=2000)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--formats", nargs="+", default=["h5-gzip", "h5-none", "usdc", "usdc-nosave"], choices=list(CONFIGS))
    args = parser.parse_args(argv)
    print(f"{'format':<12} {'points':>8} {'frames':>6} {'raw MB':>8} {'MB written':>10} {'ms/frame':>9} {'RSS growth MB':>13} {'peak RSS MB':>11}  growth over the bake (MB, 20 samples)")
    for config in args.formats:
        r = measure(config, args.points, args.frames, args.runs)
        trace = " ".join(f"{g:.0f}" for g in r["rss_growth_trace"])
        print(
            f"{r['config']:<12} {r['points']:>8} {r['frames']:>6} {r['raw_mb']:>8.0f} {r['file_mb']:>10.0f} "
            f"{r['ms_per_frame']:>9.2f} {r['rss_growth_mb']:>13.0f} {r['peak_rss_mb']:>11.0f}  {trace}",
            flush=True,
        )


if __name__ == "__main__":
    main()
