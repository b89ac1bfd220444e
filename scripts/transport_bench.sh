#!/usr/bin/env bash
# Cyclone DDS transport on this machine at hullpipe's sample sizes (docs/benchmarks.md,
# "Transport"): ddsperf ping/pong round trips and pub/sub throughput, over UDP
# loopback and over iceoryx shared memory (RouDi started here, stopped after).
# Sizes: a map's RLE runs (~4 KiB), a half-scale camera image (322x243x3 B), a
# 320x120 HullView tile (4 B depth + 3 B colour per pixel).
# Usage: scripts/transport_bench.sh [seconds per measurement, default 3]
set -euo pipefail
SECS="${1:-3}"
DIR="$(mktemp -d)"
trap 'kill $ROUDI 2>/dev/null || true; rm -rf "$DIR"' EXIT
BASE='<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface name="lo"/></Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex><Peers><Peer address="127.0.0.1"/></Peers></Discovery>%s</Domain></CycloneDDS>'
printf "$BASE" "" > "$DIR/udp.xml"
printf "$BASE" "<SharedMemory><Enable>true</Enable><LogLevel>warn</LogLevel></SharedMemory>" > "$DIR/shm.xml"
command -v iox-roudi >/dev/null || { echo "transport_bench.sh: iox-roudi missing (bash scripts/setup.sh installs iceoryx)" >&2; exit 2; }
iox-roudi > "$DIR/roudi.log" 2>&1 &
ROUDI=$!
for _ in $(seq 50); do grep -q "RouDi is ready" "$DIR/roudi.log" && break; sleep 0.1; done
DOMAIN=$((200 + RANDOM % 30))
# One row per type and size: KS (keyed sequence of octets, as hullpipe's maps,
# images and tiles) at hullpipe's sizes, and S32k, ddsperf's fixed-size 32 KiB
# type, as the control: Cyclone puts only some types into shared memory.
printf "%-6s %-9s %-5s %12s %12s %12s %12s\n" "type" "size" "path" "rtt p50 us" "rtt p90 us" "MB/s" "samples/s"
for spec in KS:4096 KS:234738 KS:268800 S32k:32768; do
  type=${spec%%:*}
  size=${spec##*:}
  sizearg=(size "$size")
  [ "$type" = KS ] || sizearg=()
  for cfg in udp shm; do
    export CYCLONEDDS_URI="file://$DIR/$cfg.xml"
    timeout $((SECS + 5)) ddsperf -i $DOMAIN -T $type -D $((SECS + 1)) pong > "$DIR/pong.log" 2>&1 &
    other=$!
    timeout $((SECS + 5)) ddsperf -i $DOMAIN -T $type -D "$SECS" ping "${sizearg[@]}" > "$DIR/ping.log" 2>&1 || true
    wait $other 2>/dev/null || true
    lat=$(grep " 50% " "$DIR/ping.log" | tail -1)
    p50=$(sed -n 's/.* 50% \([0-9.]*\)us.*/\1/p' <<<"$lat")
    p90=$(sed -n 's/.* 90% \([0-9.]*\)us.*/\1/p' <<<"$lat")
    timeout $((SECS + 5)) ddsperf -i $DOMAIN -T $type -D $((SECS + 1)) sub > "$DIR/sub.log" 2>&1 &
    other=$!
    timeout $((SECS + 5)) ddsperf -i $DOMAIN -T $type -D "$SECS" pub "${sizearg[@]}" > "$DIR/pub.log" 2>&1 || true
    wait $other 2>/dev/null || true
    # The sub's rate line: "... rate R kS/s ..." (its first rate is the one measured).
    ks=$(grep " rate " "$DIR/sub.log" | sed -n 's/.* rate \([0-9.]*\) kS\/s.*/\1/p' | sort -g | tail -1)
    printf "%-6s %-9s %-5s %12s %12s %12s %12s\n" "$type" "$size" "$cfg" "${p50:-?}" "${p90:-?}" \
      "$(awk -v k="${ks:-0}" -v s="$size" 'BEGIN{printf "%.0f", k*1000*s/1e6}')" \
      "$(awk -v k="${ks:-0}" 'BEGIN{printf "%.0f", k*1000}')"
    DOMAIN=$((DOMAIN + 1))
  done
done
