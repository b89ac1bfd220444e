#!/usr/bin/env bash
# Per-node benchmark (docs/architecture.md): records the real rig's demo traffic once
# (hullpipe_record: calibration, maps, images, view poses, tiles, object states), then runs each node
# alone with bench/node_bench, fed as fast as it takes input, and prints the
# table of docs/benchmarks.md. Usage: scripts/node_bench.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD="${1:-build}"
RIG="${RIG:-../shared/data/utrecht-4cam}"
OUT=out/node_bench
rm -rf "$OUT"; mkdir -p "$OUT"
DOMAIN=$((200 + $$ % 30))
# The launcher's loopback config, written once by a 1-frame run.
"$BUILD/bin/hullpipe_launch" --rig "$RIG" --frames 1 --out "$OUT/probe" --domain "$DOMAIN" > /dev/null
export CYCLONEDDS_URI="file://$PWD/$OUT/probe/cyclonedds.xml"
"$BUILD/bin/hullpipe_record" --domain "$DOMAIN" -o "$OUT/rig.hprec" --include 'hullpipe/camera_info' \
  --include 'hullpipe/object_pixel_map' --include 'hullpipe/camera_image' --include 'hullpipe/view_pose' \
  --include 'hullpipe/hull_view' --include 'hullpipe/object_state' \
  > "$OUT/record.log" 2>&1 &
REC=$!
sleep 1
"$BUILD/bin/hullpipe_launch" --rig "$RIG" --out "$OUT/run" --domain "$DOMAIN" \
  --dds-config "$PWD/$OUT/probe/cyclonedds.xml" > "$OUT/launch.log" 2>&1
sleep 1
kill -INT $REC; wait $REC
"$BUILD/bin/hullpipe_record" info "$OUT/rig.hprec" | tail -6
echo
echo "| node     | frames |      fps |  p50 ms  |  p95 ms  |  p99 ms  |  CPU % | peak MiB | timeouts |"
echo "|----------|--------|----------|----------|----------|----------|--------|----------|----------|"
"$BUILD/bin/node_bench" --node capture --rig "$RIG"
"$BUILD/bin/node_bench" --node recon --recording "$OUT/rig.hprec"
"$BUILD/bin/node_bench" --node render --recording "$OUT/rig.hprec"
"$BUILD/bin/node_bench" --node sim --recording "$OUT/rig.hprec"
"$BUILD/bin/node_bench" --node sim --recording "$OUT/rig.hprec" --scene scenes/particles.yaml
"$BUILD/bin/node_bench" --node sim --recording "$OUT/rig.hprec" --scene scenes/curtain.yaml
