#!/usr/bin/env bash
# The stereo frame of a recon node against its mono frame, on the real rig
# (docs/hmd.md, "What it costs"): records the demo run with --stereo once
# (calibration, maps, images and both eyes' ViewPoses), then runs recon_node
# alone on it with bench/node_bench, fed closed-loop: each frameset with both
# eyes' ViewPoses (--views all) against the same frameset with its left eye's
# alone (--views first), alternated ROUNDS times, in four deployments: the
# whole view on one thread and on the host's cores, and each of the demo's
# two tiles on one thread. Prints the medians and each round's ratio.
# Usage: scripts/stereo_node_bench.sh [BUILD_DIR]; ROUNDS (5), SIZE (320x240,
# each eye's image), RIG as scripts/demo.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD="${1:-build}"
RIG="${RIG:-../shared/data/utrecht-4cam}"
ROUNDS="${ROUNDS:-5}"
SIZE="${SIZE:-320x240}"
W="${SIZE%x*}"; H="${SIZE#*x}"
OUT=out/stereo_node_bench
rm -rf "$OUT"; mkdir -p "$OUT"
DOMAIN=$((200 + $$ % 30))
# The launcher's loopback config, written once by a 1-frame run.
"$BUILD/bin/hullpipe_launch" --rig "$RIG" --frames 1 --out "$OUT/probe" --domain "$DOMAIN" > /dev/null 2>&1
export CYCLONEDDS_URI="file://$PWD/$OUT/probe/cyclonedds.xml"
"$BUILD/bin/hullpipe_record" --domain "$DOMAIN" -o "$OUT/stereo.hprec" --include 'hullpipe/camera_info' \
  --include 'hullpipe/object_pixel_map' --include 'hullpipe/camera_image' --include 'hullpipe/view_pose' \
  > "$OUT/record.log" 2>&1 &
REC=$!
sleep 1
"$BUILD/bin/hullpipe_launch" --rig "$RIG" --out "$OUT/run" --domain "$DOMAIN" --stereo --width "$W" --height "$H" \
  --dds-config "$PWD/$OUT/probe/cyclonedds.xml" > "$OUT/launch.log" 2>&1
sleep 1
kill -INT $REC; wait $REC
"$BUILD/bin/hullpipe_record" info "$OUT/stereo.hprec" | grep -E "view_pose|camera_image" >&2
bench() {  # tile threads views -> one JSON line
  "$BUILD/bin/node_bench" --node recon --recording "$OUT/stereo.hprec" --tile "$1" --threads "$2" --views "$3" \
    --json 2> "$OUT/bench.err"
}
for deployment in "0/1 1" "0/1 0" "0/2 1" "1/2 1"; do
  read -r tile threads <<< "$deployment"
  for ((r = 0; r < ROUNDS; ++r)); do
    # The order swapped each round, so the machine's drift falls on both.
    if ((r % 2 == 0)); then order="first all"; else order="all first"; fi
    for views in $order; do
      echo "$tile $threads $r $(bench "$tile" "$threads" "$views")" >> "$OUT/runs.txt"
    done
  done
done
python3 - "$OUT/runs.txt" "$SIZE" "$ROUNDS" <<'EOF'
import json, statistics, sys
runs = {}
for line in open(sys.argv[1]):
    tile, threads, r, js = line.split(" ", 3)
    j = json.loads(js)
    runs.setdefault((tile, threads), {}).setdefault(int(r), {})[j["views"]] = j
print(f"recon_node on the rig's stereo recording, eyes {sys.argv[2]}, {sys.argv[3]} alternated rounds "
      "(CPU: the node's user+system ms per frameset; latency: p50 ms, frameset written -> last HullView)\n")
print("| recon node | threads | CPU ms one eye | CPU ms two eyes | two / one (each round) | "
      "latency ms one / two | framesets | timeouts |")
print("|---|---|---|---|---|---|---|---|")
for (tile, threads), rounds in runs.items():
    one = [x["first"] for x in rounds.values()]
    two = [x["all"] for x in rounds.values()]
    ratios = sorted(b["cpu_ms_per_frameset"] / a["cpu_ms_per_frameset"] for a, b in zip(one, two))
    med = lambda xs, k: statistics.median(x[k] for x in xs)
    name = "whole view" if tile == "0/1" else f"tile {tile}"
    print(f"| {name} | {threads if threads != '0' else 'host (0)'} | {med(one, 'cpu_ms_per_frameset'):.2f} | "
          f"{med(two, 'cpu_ms_per_frameset'):.2f} | {statistics.median(ratios):.2f} "
          f"({', '.join(f'{x:.2f}' for x in ratios)}) | {med(one, 'latency_ms_p50'):.1f} / "
          f"{med(two, 'latency_ms_p50'):.1f} | {one[0]['frames']} | "
          f"{sum(x['timeouts'] for x in one + two)} |")
EOF
