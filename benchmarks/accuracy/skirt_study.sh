#!/usr/bin/env bash
# Work-precision study of the solvers on the bundled skirt (examples/skirt/scene.toml, no
# wind), plotting max strain: a draping skirt buckles into folds whose places depend on
# round-off, so position against a reference is not a stable error measure there; stretch is.
#   bash benchmarks/accuracy/skirt_study.sh [OUT_DIR]     (a few minutes)
set -euo pipefail
out=${1:-benchmarks/figures/skirt-study}
scene=examples/skirt/scene.toml
common=(--set 'wind.velocity=[0,0,0]' --metric strain --reference solver.preset=physical --repeats 3 -o "$out")
clothtool study "$scene" --sweep solver.frequency=24,48,96,192,384,768 \
    --sweep solver.preset=production,physical,implicit "${common[@]}"
clothtool study "$scene" --sweep solver.frequency=24000,48000 --sweep solver.preset=explicit "${common[@]}" --append
