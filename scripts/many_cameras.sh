#!/usr/bin/env bash
# A published dome's size on this machine (docs/benchmarks.md, "Many cameras"):
# the synthetic figure seen by 20 distorted cameras at 1024x768 (hullpipe_rig
# synthesize: k1 -0.04, sensor noise, videos segmented as a real rig's), run by
# the five processes with capture paced at each --fps given, render saving
# every frame's depth; then `vh_eval run` checks the first composited frames
# against the same frames' direct sweep (pixel for pixel) and exact hull.
# Writes out/many_cameras/ (the rig, a run per rate, vh_eval's JSON per run)
# and prints a row per rate.
# Usage: scripts/many_cameras.sh [BUILD_DIR] [FPS...]   (defaults: build, 2 5)
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD="${1:-build}"
shift || true
RATES=("$@")
[ ${#RATES[@]} -gt 0 ] || RATES=(2 5)
CAMERAS="${CAMERAS:-20}" SIZE="${SIZE:-1024x768}" FRAMES="${FRAMES:-40}" CHECK="${CHECK:-4}" STRIDE="${STRIDE:-8}"
OUT=out/many_cameras
mkdir -p "$OUT"
if [ ! -f "$OUT/rig/rig.yaml" ]; then
  echo "synthesizing $CAMERAS cameras at $SIZE, $FRAMES frames" >&2
  "$BUILD/bin/hullpipe_rig" synthesize -o "$OUT/rig" --cameras "$CAMERAS" --size "$SIZE" --frames "$FRAMES" \
    --format yaml > "$OUT/synthesize.log" 2>&1 || { echo "synthesize failed: see $OUT/synthesize.log" >&2; exit 1; }
fi
# launch/local.yaml with render saving each frame's depth and view.
sed 's/--png-every, "50"/--png-every, "1", --save-depth/' launch/local.yaml > "$OUT/save_depth.yaml"
grep -q -- '--save-depth' "$OUT/save_depth.yaml" || { echo "launch/local.yaml changed: no --png-every to replace" >&2; exit 1; }
printf '%-6s %-12s %-11s %-16s %-22s %s\n' fps composited render_fps "p50/p95 ms" "= direct sweep px" "exact: only run / only exact / worst median mm"
for fps in "${RATES[@]}"; do
  run="$OUT/run_fps$fps"
  rm -rf "$run"
  "$BUILD/bin/hullpipe_launch" --rig "$OUT/rig/rig.yaml" --frames "$FRAMES" --fps "$fps" --out "$run" \
    --description "$OUT/save_depth.yaml" > "$run.log" 2>&1 || { echo "the run at --fps $fps failed: see $run.log" >&2; exit 1; }
  "$BUILD/bin/vh_eval" run --rig "$OUT/rig/rig.yaml" --run "$run" --max-frames "$CHECK" --exact-stride "$STRIDE" \
    --json > "$run.vh_eval.json" 2> "$run.vh_eval.log" || { echo "vh_eval run failed: see $run.vh_eval.log" >&2; exit 1; }
  python3 - "$run/stats.json" "$run.vh_eval.json" "$fps" "$FRAMES" <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); e = json.load(open(sys.argv[2]))
r = s["nodes"]["render"]
print(f'{sys.argv[3]:<6} {s["frames_composited"]:>3} of {sys.argv[4]:<5} {r["fps"]:<11.1f} '
      f'{r["latency_ms_p50"]:.0f}/{r["latency_ms_p95"]:.0f}{"":<8} '
      f'{e["equal_to_sweep"]} of {e["pixels"]:<10} {e["only_run"]} / {e["only_exact"]} of {e["exact_both"]} / '
      f'{e["worst_frame_err_mm_median"]:.2f}')
PY
done
