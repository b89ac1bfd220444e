#!/usr/bin/env bash
# Speed against error of the plane sweep (paper §3.3; docs/benchmarks.md): runs `vh_eval sweep` on the
# synthetic scene, writes docs/sweep.json, docs/sweep.tsv and the plot
# docs/images/sweep_pareto.png. Takes about ten minutes on two cores.
# Usage: scripts/eval_sweep.sh [BUILD_DIR] [extra vh_eval sweep flags]
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD="${1:-build}"
shift || true
"$BUILD/bin/vh_eval" sweep --json --tsv docs/sweep.tsv "$@" > docs/sweep.json
gnuplot -e "data='docs/sweep.tsv'; out='docs/images/sweep_pareto.png'" docs/plots/sweep.gp
echo "wrote docs/sweep.json, docs/sweep.tsv, docs/images/sweep_pareto.png"
