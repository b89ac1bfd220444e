#!/usr/bin/env bash
# Runs every hybrid scene (scenes/*.yaml but the plain ball demo) on the
# real rig and on the synthetic source, each from one launch command, and writes
# their videos under out/scenes/<scene>_<source>/ and one frame of each into
# docs/images/scenes.png (top row: the real rig; bottom: synthetic).
# Usage: scripts/scenes.sh [BUILD_DIR]   (after scripts/demo.sh has built once)
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD="${1:-build}"
RIG="${RIG:-../shared/data/utrecht-4cam}"
SCENES=(ball_blocks curtain particles lighting payload)
rows=()
for source in rig synthetic; do
  inputs=()
  for s in "${SCENES[@]}"; do
    out="out/scenes/${s}_${source}"
    rm -rf "$out"; mkdir -p "$out"
    if [ "$source" = rig ]; then src=(--rig "$RIG" --frames 200); else src=(--synthetic --frames 120); fi
    extra=()
    [ "$s" = curtain ] && extra=(--head-poses scenes/head_track_example.csv)
    "$BUILD/bin/hullpipe_launch" "${src[@]}" --scene "scenes/$s.yaml" --out "$out" "${extra[@]}" > "$out.log" 2>&1 \
      || { echo "scene $s on $source failed: see $out.log" >&2; exit 1; }
    frame=$(ls "$out"/frame_*.png | sort | tail -1)
    inputs+=(-i "$frame")
    echo "$s on $source: $out/hullpipe.mp4 ($frame)"
  done
  ffmpeg -loglevel error -y "${inputs[@]}" -filter_complex "hstack=inputs=${#SCENES[@]}" "out/scenes/row_$source.png"
  rows+=(-i "out/scenes/row_$source.png")
done
ffmpeg -loglevel error -y "${rows[@]}" -filter_complex "vstack=inputs=2" docs/images/scenes.png
echo "wrote docs/images/scenes.png"
