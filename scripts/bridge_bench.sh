#!/usr/bin/env bash
# render_node's rate with and without hullpipe_bridge serving a client that
# subscribes to the images, maps and hull views and never reads (mode bridge),
# or one that watches the viewable channels and reads everything (mode
# viewable: every camera's image and map, the hull view, render's composite, the hull points, the scene:
# the bridge encodes their JPEGs and PNGs) (docs/benchmarks.md, "Live view"):
# the five-process demo on the real rig, three runs of each mode, alternating.
# MODES="none bridge viewable" by default. Prints render's fps, latency p50 and
# frames composited per run, and what the viewing client received.
set -euo pipefail
cd "$(dirname "$0")/.."
RIG="${RIG:-../shared/data/utrecht-4cam}"
OUT=$(mktemp -d /tmp/hullpipe_bridge_bench.XXXXXX)
DOMAIN=$(( 150 + RANDOM % 50 ))
rm -rf $OUT/probe; build/bin/hullpipe_launch --rig "$RIG" --frames 1 --out "$OUT/probe" --domain "$DOMAIN" > /dev/null 2>&1
export CYCLONEDDS_URI="file://$OUT/probe/cyclonedds.xml"
JS=tests/js
for i in 1 2 3; do
  for mode in ${MODES:-none bridge viewable}; do
    rm -rf $OUT/$mode$i
    if [ $mode = bridge ]; then
      build/bin/hullpipe_bridge --domain $DOMAIN --port 0 > $OUT/bridge$i.log 2>&1 & BR=$!
      sleep 1; PORT=$(grep -o "ws://127.0.0.1:[0-9]*" $OUT/bridge$i.log | head -1 | cut -d: -f3)
      node -e "const W=require('$PWD/$JS/node_modules/ws');const w=new W('ws://127.0.0.1:$PORT',['foxglove.websocket.v1']);w.on('message',(d,bin)=>{if(bin)return;const m=JSON.parse(d);if(m.op==='advertise'){let id=1;const subs=m.channels.filter(c=>['hullpipe/camera_image','hullpipe/hull_view','hullpipe/object_pixel_map'].includes(c.topic)).map(c=>({id:id++,channelId:c.id}));w.send(JSON.stringify({op:'subscribe',subscriptions:subs}));setTimeout(()=>w._socket.pause(),300);}});setTimeout(()=>process.exit(0),60000);" & CL=$!
      sleep 1
    fi
    if [ $mode = viewable ]; then
      build/bin/hullpipe_bridge --domain $DOMAIN --port 0 > $OUT/bridge$i.log 2>&1 & BR=$!
      sleep 1; PORT=$(grep -o "ws://127.0.0.1:[0-9]*" $OUT/bridge$i.log | head -1 | cut -d: -f3)
      node -e "const W=require('$PWD/$JS/node_modules/ws');const w=new W('ws://127.0.0.1:$PORT',['foxglove.websocket.v1']);let id=1,n=0,bytes=0;w.on('message',(d,bin)=>{if(bin){n++;bytes+=d.length;return;}const m=JSON.parse(d);if(m.op==='advertise'){const subs=m.channels.filter(c=>/^\/foxglove\/(cam[0-9]+\/(image|object_pixel_map)|hull_view|composited|hull_points|scene)$/.test(c.topic)).map(c=>({id:id++,channelId:c.id}));if(subs.length)w.send(JSON.stringify({op:'subscribe',subscriptions:subs}));}});process.on('SIGTERM',()=>{console.log('viewer got '+n+' messages, '+(bytes/1048576).toFixed(1)+' MiB');process.exit(0);});" > $OUT/viewer$i.log 2>&1 & CL=$!
      sleep 1
    fi
    build/bin/hullpipe_launch --rig "$RIG" --out "$OUT/$mode$i" --domain "$DOMAIN" --dds-config "$OUT/probe/cyclonedds.xml" > $OUT/launch_$mode$i.log 2>&1 || echo "launch $mode$i rc=$?"
    if [ $mode != none ]; then kill -INT $BR; wait $BR || true; kill $CL 2>/dev/null || true; wait $CL 2>/dev/null || true; grep -o "stopped.*" $OUT/bridge$i.log; fi
    if [ $mode = viewable ]; then cat $OUT/viewer$i.log; fi
    python3 -c "
import json; j=json.load(open('$OUT/$mode$i/stats.json')); r=j['nodes']['render']
print('$mode$i', 'render fps %.2f p50 %.0f ms composited %d' % (r['fps'], r['latency_ms_p50'], j['frames_composited']))"
  done
done
