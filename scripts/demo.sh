#!/usr/bin/env bash
# README command (1): install what is needed, build, and run the five-process demo
# on the real 4-camera rig. Extra arguments go to hullpipe_launch
# (e.g. --frames 100, --out DIR, --synthetic instead of the rig).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build
# The defaults (the Utrecht rig, out/) only where the arguments name no other:
# hullpipe_launch takes each option once.
defaults=()
given() { local a; for a in "${@:2}"; do [[ "$a" == "$1" || "$a" == "$1="* ]] && return 0; done; return 1; }
if ! given --synthetic "$@" && ! given --rig "$@"; then defaults+=(--rig "${RIG:-../shared/data/utrecht-4cam}"); fi
given --out "$@" || defaults+=(--out "${OUT:-out}")
exec ./build/bin/hullpipe_launch "${defaults[@]}" "$@"
