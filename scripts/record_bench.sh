#!/usr/bin/env bash
# The recorder's end-to-end throughput over DDS at 1 MiB samples (docs/benchmarks.md,
# "Recording throughput"): for each storage (SQLite .hprec, MCAP .mcap) and
# compression (none, zstd; MCAP also lz4), hullpipe_record takes
# N camera images of 1 MiB from record_bench --publish (each acknowledged before
# the next: lossless), then `info` says what it stored and lost.
#   N=256 bash scripts/record_bench.sh
set -euo pipefail
cd "$(dirname "$0")/.."
N="${N:-256}"
BIN=build/bin
OUT=$(mktemp -d /tmp/hullpipe_record_bench.XXXXXX)
trap 'rm -rf "$OUT"' EXIT
cat > "$OUT/lo.xml" <<XML
<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface name="lo"/></Interfaces>
<AllowMulticast>false</AllowMulticast></General><Discovery><Peers><Peer address="127.0.0.1"/></Peers>
<ParticipantIndex>auto</ParticipantIndex></Discovery></Domain></CycloneDDS>
XML
export CYCLONEDDS_URI="file://$OUT/lo.xml"
DOMAIN=$(( 150 + RANDOM % 50 ))
for v in hprec:none hprec:zstd mcap:none mcap:zstd mcap:lz4; do
  ext=${v%%:*}; c=${v##*:}; f="$OUT/$c.$ext"
  "$BIN/hullpipe_record" --domain "$DOMAIN" -o "$f" --compression "$c" --depth 64 > "$OUT/$c.$ext.log" 2>&1 &
  rec=$!
  "$BIN/record_bench" --publish "$N" --domain "$DOMAIN" | sed "s/^/$ext $c: /"
  kill -INT "$rec"; wait "$rec" || true
  "$BIN/hullpipe_record" info "$f" --json | python3 -c "
import json,sys; j=json.load(sys.stdin); t=[x for x in j['topics'] if x['name']=='hullpipe/camera_image'][0]
print('$ext $c: recorded %d of $N, lost %s, %.1f MB raw, %.1f MB stored, %.1f MB on disk' % (t['count'], t['lost'], t['bytes']/1e6, t['stored_bytes']/1e6, j['file_bytes']/1e6))"
done
