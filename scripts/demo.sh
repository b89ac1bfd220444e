#!/usr/bin/env bash
# README command (1): install what is needed, build, and run the five-process demo
# on the real 4-camera rig. Extra arguments go to hullpipe_launch
# (e.g. --frames 100, --out DIR, --synthetic instead of the rig).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build
RIG="${RIG:-../shared/data/utrecht-4cam}"
if [[ " $* " == *" --synthetic "* ]]; then
  exec ./build/bin/hullpipe_launch --out "${OUT:-out}" "$@"
fi
exec ./build/bin/hullpipe_launch --rig "$RIG" --out "${OUT:-out}" "$@"
