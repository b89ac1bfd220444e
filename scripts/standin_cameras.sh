#!/usr/bin/env bash
# Stand-in live cameras: streams each camera's video of the rig in real time over
# UDP (MPEG-TS, MPEG-4 part 2, a key frame every 10 frames, each frame sent as recorded) to 127.0.0.1:BASE+id,
# as network cameras would; capture_node reads them with a rig file whose frames
# are those URLs (hullpipe_rig convert --frames 'udp://127.0.0.1:{BASE+id}').
#   bash scripts/standin_cameras.sh [RIG] [BASE=5000] [SECONDS=0: the whole video]
# Stops (all streams) on Ctrl-C.
set -euo pipefail
RIG=${1:-"$(dirname "$0")/../../shared/data/utrecht-4cam"}
BASE=${2:-5000}
SECONDS_OPT=()
[ "${3:-0}" != 0 ] && SECONDS_OPT=(-t "$3")
pids=()
trap 'kill "${pids[@]}" 2>/dev/null || true' INT TERM EXIT
for dir in "$RIG"/cam*/; do
  id=${dir%/}; id=${id##*/cam}
  ffmpeg -nostdin -hide_banner -loglevel error -re -i "$dir/video.avi" "${SECONDS_OPT[@]}" -an \
    -fps_mode vfr -enc_time_base 1/50 -c:v mpeg4 -q:v 3 -g 10 -f mpegts "udp://127.0.0.1:$((BASE + id))?pkt_size=1316" &
  pids+=($!)
  echo "camera $id: udp://127.0.0.1:$((BASE + id))"
done
wait "${pids[@]}"
