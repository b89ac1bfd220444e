#!/usr/bin/env bash
# The batting scenes (docs/collision.md, "Hull velocity"): the synthetic figure
# bats two resting balls away with its waving hand (scenes/bat.yaml), and the
# same idea on the real rig (scenes/bat_rig.yaml). Writes out/bat_{synthetic,rig}/
# (video, frames, stats.json), prints each run's hull velocity counts and
# speeds, and stacks frames of the synthetic run into docs/images/bat.png.
# Usage: scripts/bat.sh [BUILD_DIR]   (after scripts/demo.sh has built once)
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD="${1:-build}"
RIG="${RIG:-../shared/data/utrecht-4cam}"
run() {  # name, source args..., scene
  local name=$1 scene=$2; shift 2
  local out="out/bat_$name"
  rm -rf "$out"; mkdir -p "$out"
  "$BUILD/bin/hullpipe_launch" "$@" --scene "$scene" --out "$out" > "$out.log" 2>&1 \
    || { echo "bat on $name failed: see $out.log" >&2; exit 1; }
  python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print(sys.argv[2], 'frames', j['frames_composited'], 'hull_velocity', json.dumps(j['hull_velocity']))" \
    "$out/stats.json" "$name"
}
run synthetic scenes/bat.yaml --synthetic --frames 150
run rig scenes/bat_rig.yaml --rig "$RIG" --frames 300
# Four composited frames of the synthetic run (the orbit view, its upper
# middle): the balls at rest, the hand striking one (red), the balls leaving.
ffmpeg -loglevel error -y -i out/bat_synthetic/hullpipe.mp4 \
  -vf "select='eq(n\\,2)+eq(n\\,5)+eq(n\\,12)+eq(n\\,24)',crop=iw/2:ih/2:iw/4:0,scale=iw*2:-1,tile=4x1" \
  -frames:v 1 docs/images/bat.png
echo "wrote docs/images/bat.png"
