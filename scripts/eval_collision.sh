#!/usr/bin/env bash
# Collision detection and response against exact ground truth (paper §4; docs/benchmarks.md): runs
# `vh_eval collision` on the synthetic scenes, writes docs/collision.json,
# docs/collision.tsv and the plot docs/images/collision_speed_error.png.
# Takes about a minute on two cores.
# Usage: scripts/eval_collision.sh [BUILD_DIR] [extra vh_eval collision flags]
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD="${1:-build}"
shift || true
"$BUILD/bin/vh_eval" collision --json --tsv docs/collision.tsv "$@" > docs/collision.json
gnuplot -e "data='docs/collision.tsv'; out='docs/images/collision_speed_error.png'" docs/plots/collision.gp
echo "wrote docs/collision.json, docs/collision.tsv, docs/images/collision_speed_error.png"
