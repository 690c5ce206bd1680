#!/usr/bin/env bash
# The swing study's convergence in both state precisions: examples/sheet/swing.toml (XPBD, the
# `physical` preset, its full second) at 96..6144 Hz in float64 (the default) and float32,
# against the study's converged float64 reference. In float64 the error falls at every doubling
# up to 6144 Hz; in float32 it turns back up once round-off (measured against each run's
# float64 twin, the dotted line) reaches it. Also prints the time to reach 0.2% of the size.
#   bash benchmarks/accuracy/swing_convergence.sh [OUT_DIR]     (about a minute)
set -euo pipefail
out=${1:-benchmarks/figures/swing-convergence}
clothtool study examples/sheet/swing.toml --sweep solver.frequency=96,192,384,768,1536,3072,6144 \
    --sweep solver.precision=float64,float32 --set 'solver.preset="physical"' \
    --reference 'solver.preset="physical"' --target-error 0.002 --repeats 3 -o "$out"
