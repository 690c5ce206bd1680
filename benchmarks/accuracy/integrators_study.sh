#!/usr/bin/env bash
# Work-precision study of the four solvers on the swinging sheet (examples/sheet/swing.toml):
# NvCloth-style PBD (log-space stiffness), PBD with XPBD compliance, implicit Baraff-Witkin,
# and the explicit mass-spring baseline, against an XPBD float64 reference.
#   bash benchmarks/accuracy/integrators_study.sh [OUT_DIR]     (about 10 minutes)
set -euo pipefail
out=${1:-benchmarks/figures/sheet-study}
scene=examples/sheet/swing.toml
common=(--reference solver.preset=physical --reference-frequency 9600 --repeats 3 -o "$out")
clothtool study "$scene" --sweep solver.frequency=24,48,96,192,384,768 \
    --sweep solver.preset=production,physical,implicit "${common[@]}"
# the explicit integrator is stable only from about 10 kHz on this sheet: its own frequencies
clothtool study "$scene" --sweep solver.frequency=12000,24000,48000 --sweep solver.preset=explicit \
    "${common[@]}" --append
