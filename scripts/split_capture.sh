#!/usr/bin/env bash
# Cameras on two capture nodes against one: composited frames on the real rig with
# capture nodes 1,2 and 3,4 started DELAY seconds apart (launch/split-capture.yaml)
# and with one capture node for all four (launch/local.yaml), same settings,
# alternated RUNS times in one sitting; prints each run and the medians.
#   bash scripts/split_capture.sh [RUNS=3] [FRAMES=300] [DELAYS="0.3 1.5"]
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS=${1:-3}
FRAMES=${2:-300}
DELAYS=${3:-"0.3 1.5"}
RIG=${HULLPIPE_RIG:-../shared/data/utrecht-4cam}
# CAPTURE_FPS=25: pace every capture node at that rate (on two cores one node for
# four cameras cannot keep the rig's 50 fps and skips frames, leaving recon more CPU
# than two nodes that keep up do; at 25 fps both keep up and compare like for like).
CAPTURE_FPS=${CAPTURE_FPS:-}
[ -x build/bin/hullpipe_launch ] || { cmake -S . -B build -G Ninja >/dev/null && ninja -C build >/dev/null; }
OUT=$(mktemp -d /tmp/hullpipe_split.XXXXXX)
declare -A results
for run in $(seq "$RUNS"); do
  for cfg in one $DELAYS; do
    src=launch/local.yaml
    [ "$cfg" != one ] && src=launch/split-capture.yaml
    desc="$OUT/desc_$cfg.yaml"
    sed "s/start_delay: .*/start_delay: $cfg/" "$src" > "$desc"
    [ -n "$CAPTURE_FPS" ] && sed -i "/\\\${source}/s/--frames, \"\${frames}\",/--frames, \"\${frames}\", --fps, \"$CAPTURE_FPS\",/" "$desc"
    dir="$OUT/$cfg-$run"
    build/bin/hullpipe_launch --description "$desc" --rig "$RIG" --frames "$FRAMES" --out "$dir" > "$dir.log" 2>&1 ||
      { echo "run $cfg-$run failed: $dir.log" >&2; exit 1; }
    n=$(python3 -c "import json; j=json.load(open('$dir/stats.json')); print(j['frames_composited'])")
    skew=$(python3 -c "
import json; j=json.load(open('$dir/stats.json'))
c=j['framesets']['render']['cameras']; print(max(v['skew_ms_p95'] for v in c.values()) if c else 0)")
    echo "run $run  capture ${cfg/one/one node}  composited $n  skew p95 max ${skew} ms"
    results[$cfg]+="$n "
  done
done
median() { tr ' ' '\n' | grep . | sort -n | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
one=$(echo "${results[one]}" | median)
echo "median composited: one node $one"
for d in $DELAYS; do
  m=$(echo "${results[$d]}" | median)
  echo "median composited: two nodes ${d} s apart $m ($(python3 -c "print(f'{100*$m/$one:.0f}')")% of one node)"
done
