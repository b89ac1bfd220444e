#!/usr/bin/env bash
# Many cameras at camera rate (docs/benchmarks.md, "Many cameras on a GPU
# machine"): in one call, on a machine with a GPU, the rows a lab would try --
# the GL frame and the triangle query (hullpipe_bench --backend), the query
# set-up against the number of cameras (scaling_bench), and the five processes
# on the 4-camera demo, synthesized 16-camera 640x480 and 20-camera 1024x768
# rigs (60 frames at 25 fps) and the published 20-camera dome as 30 stills at
# 25 fps, on the GL and CPU backends -- then one table. Without a hardware GPU
# it runs the CPU rows and says the GPU rows were not measured.
#
# Usage: scripts/gpu_scale.sh BINDIR OUT
#   BINDIR  a build's bin/ or a bundle's (scripts/bundle_binaries.py: its lib/
#           beside it goes on LD_LIBRARY_PATH)
#   OUT     results: table.md, summary.json, per run its stats.json and log
# Environment: RIG (the Utrecht rig, default ../shared/data/utrecht-4cam), DOME
# (the published dome, default ../shared/data/dome-20cam), RIGS (where the
# synthesized rigs are kept between runs, default OUT/rigs), QUICK=1 (fewer
# bench rows), ROWS (which rows, default all: "bench scaling demo4 engine4
# syn16 syn16jpeg syn20 dome30"; also syn16raw, syn20raw: capture --jpeg 0), BACKENDS (default "gl cpu" with a GPU, "cpu"
# without).
set -uo pipefail
cd "$(dirname "$0")/.."
[ $# -eq 2 ] || { echo "usage: scripts/gpu_scale.sh BINDIR OUT" >&2; exit 2; }
BIN="$(cd "$1" && pwd)" || { echo "gpu_scale: BINDIR $1 not found" >&2; exit 2; }
OUT="$2"
mkdir -p "$OUT" || exit 2
OUT="$(cd "$OUT" && pwd)"
[ -d "$BIN/../lib" ] && export LD_LIBRARY_PATH="$BIN/../lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
RIG="${RIG:-../shared/data/utrecht-4cam}"
DOME="${DOME:-../shared/data/dome-20cam}"
RIGS="${RIGS:-$OUT/rigs}"
for exe in hullpipe_bench scaling_bench hullpipe_rig hullpipe_launch capture_node recon_node sim_node render_node; do
  [ -x "$BIN/$exe" ] || { echo "gpu_scale: $BIN/$exe missing" >&2; exit 2; }
done
say() { echo "== gpu_scale: $* ($(date -u +%H:%M:%S), ${SECONDS} s in)" >&2; }
ROWS=" ${ROWS:-bench scaling demo4 engine4 syn16 syn16jpeg syn20 dome30} "
want() { [[ "$ROWS" == *" $1 "* ]]; }

# A hardware GL renderer? (the bench's header names it; llvmpipe is software)
"$BIN/hullpipe_bench" --backend gl --cameras 4 --sizes 64x48 --planes 8 --triangles 0 --repeats 1 \
  > "$OUT/gl_probe.txt" 2> "$OUT/gl_probe.err"
GL_LINE="$(grep -m1 '^backend table' "$OUT/gl_probe.txt" | sed 's/.*GL: //')"
GPU=0
if [ -n "$GL_LINE" ] && ! grep -qiE 'llvmpipe|softpipe|swrast|not run' <<<"$GL_LINE"; then GPU=1; fi
say "GL: ${GL_LINE:-none} (hardware: $GPU); $(nproc) cores"

# The frame and the triangle query.
if [ "$GPU" = 1 ] && want bench; then
  say "hullpipe_bench --backend gl"
  if [ "${QUICK:-0}" = 1 ]; then rows=(--cameras 8,16 --sizes 640x480 --planes 100 --triangles 100000)
  else rows=(--cameras 4,8,16 --sizes 640x480 --planes 100 --triangles 720,10000,100000); fi
  "$BIN/hullpipe_bench" --backend gl "${rows[@]}" --repeats 5 > "$OUT/bench_gl.md" 2> "$OUT/bench_gl.err"
  # The CPU's triangle query beside it, one thread (sim_node's default).
  "$BIN/hullpipe_bench" --backend cpu --cameras 4 --sizes 64x48 --planes 8 --triangles 100000 --repeats 3 \
    > "$OUT/bench_cpu_tri.md" 2> "$OUT/bench_cpu_tri.err"
fi
# The published dome's hull box search on this machine's cores (recon's hull_box
# stage: the query's set-up at 1, 2, 6 and 8 threads), with its per-frame rows.
if want bench && [ -f "$DOME/rig.yaml" ]; then
  say "hullpipe_bench on the published dome"
  "$BIN/hullpipe_bench" --rig "$DOME/rig.yaml" --frame 0 --no-gl --repeats 5 > "$OUT/bench_dome.md" 2> "$OUT/bench_dome.err"
fi
if want scaling; then
  say "scaling_bench"
  "$BIN/scaling_bench" --sizes 644x486,1024x768 --repeats 3 > "$OUT/scaling.txt" 2> "$OUT/scaling.err"
fi

# Rigs, synthesized as a lab would (25 fps sources, other settings default).
synth() {  # name cameras size
  if [ ! -f "$RIGS/$1/rig.yaml" ]; then
    say "synthesizing $1 ($2 cameras, $3, 60 frames)"
    # (--threads: cameras rendered at once; the files are the same whatever the number)
    "$BIN/hullpipe_rig" synthesize -o "$RIGS/$1" --cameras "$2" --size "$3" --frames 60 --format yaml \
      --threads "$(( $(nproc) < 64 ? $(nproc) : 64 ))" \
      > "$OUT/synth_$1.log" 2>&1 || { echo "gpu_scale: synthesize $1 failed: $OUT/synth_$1.log" >&2; return 1; }
  fi
}
# The dome's one frame as 30 identical stills (its README).
dome30() {
  local d="$RIGS/dome30"
  [ -f "$d/rig.yaml" ] && return 0
  [ -f "$DOME/rig.yaml" ] || { echo "gpu_scale: $DOME/rig.yaml not found" >&2; return 1; }
  mkdir -p "$d" && cp "$DOME/rig.yaml" "$d/"
  for c in "$DOME"/cam*; do
    local n; n="$(basename "$c")"
    mkdir -p "$d/$n" && cp "$c/frame_0000.png" "$c/mask_0000.png" "$d/$n/"
    for i in $(seq 1 29); do
      ln -sf frame_0000.png "$d/$n/frame_$(printf %04d "$i").png"
      ln -sf mask_0000.png "$d/$n/mask_$(printf %04d "$i").png"
    done
  done
}

run() {  # name backend rig [launch flags...]
  local name="$1" backend="$2" rig="$3"
  shift 3
  local dir="$OUT/run_${name}_${backend}"
  rm -rf "$dir"
  say "run $name on $backend"
  timeout 120 "$BIN/hullpipe_launch" --rig "$rig" --backend "$backend" --out "$dir" --bin-dir "$BIN" \
    --description "${DESC:-launch/local.yaml}" --scene "${SCENE:-scenes/ball.yaml}" "$@" > "$OUT/run_${name}_${backend}.log" 2>&1
  echo "$name $backend $? $dir" >> "$OUT/runs.txt"
}

rm -f "$OUT/runs.txt"
touch "$OUT/runs.txt"
if [ -n "${BACKENDS:-}" ]; then read -r -a backends <<<"$BACKENDS"
elif [ "$GPU" = 1 ]; then backends=(gl cpu)
else backends=(cpu); fi
if want demo4; then
  for b in "${backends[@]}"; do run demo4 "$b" "$RIG"; done
fi
# The demo with the engine (scenes/engine.yaml: Debian's 2CylinderEngine before
# the seated person): sim's CAD models through the triangle query auto picks.
if want engine4; then
  for b in "${backends[@]}"; do SCENE=scenes/engine.yaml run engine4 "$b" "$RIG"; done
fi
if { want syn16 || want syn16jpeg; } && synth syn16 16 640x480; then
  if want syn16; then
    for b in "${backends[@]}"; do run syn16 "$b" "$RIGS/syn16/rig.yaml"; done
  fi
  # The same with capture's images as JPEG (capture_node --jpeg 90): what the
  # transport carries to the recon nodes, 10x smaller.
  if [ "$GPU" = 1 ] && want syn16jpeg; then
    sed 's/"${pace}"]/"${pace}", --jpeg, "90"]/' launch/local.yaml > "$OUT/jpeg.yaml"
    DESC="$OUT/jpeg.yaml" run syn16jpeg gl "$RIGS/syn16/rig.yaml"
  fi
  # ...and as raw BGR8 (--jpeg 0), what capture sent by default before a
  # frame's large images went out as JPEG (nodes/capture_controller.h).
  if [ "$GPU" = 1 ] && want syn16raw; then
    sed 's/"${pace}"]/"${pace}", --jpeg, "0"]/' launch/local.yaml > "$OUT/raw.yaml"
    DESC="$OUT/raw.yaml" run syn16raw gl "$RIGS/syn16/rig.yaml"
  fi
fi
if [ "$GPU" = 1 ] && { want syn20 || want syn20raw; } && synth syn20 20 1024x768; then
  want syn20 && run syn20 gl "$RIGS/syn20/rig.yaml"
  if want syn20raw; then
    sed 's/"${pace}"]/"${pace}", --jpeg, "0"]/' launch/local.yaml > "$OUT/raw.yaml"
    DESC="$OUT/raw.yaml" run syn20raw gl "$RIGS/syn20/rig.yaml"
  fi
fi
if want dome30 && dome30; then
  for b in "${backends[@]}"; do run dome30 "$b" "$RIGS/dome30/rig.yaml" --frames 30; done
  [ "$GPU" = 1 ] || run dome30_fps2 cpu "$RIGS/dome30/rig.yaml" --frames 30 --fps 2
fi

say "table"
python3 - "$OUT" "$GPU" "$GL_LINE" <<'PY'
import json, os, sys
out, gpu, gl_line = sys.argv[1], sys.argv[2] == "1", sys.argv[3]
rows, summary = [], {"gl": gl_line, "hardware_gpu": gpu, "cores": os.cpu_count(), "runs": {}}
def stage(node, name, q="ms_p50"):
    s = node.get("stages_ms", {}).get(name)
    return s[q] if s else float("nan")
for line in open(os.path.join(out, "runs.txt")):
    name, backend, rc, d = line.split()
    try:
        s = json.load(open(os.path.join(d, "stats.json")))
    except Exception as e:
        rows.append(f"| {name} | {backend} | exit {rc}: no stats.json | | | | | | | |")
        continue
    n = s["nodes"]
    r, cap = n.get("render", {}), n.get("capture", {})
    recon = [n[k] for k in sorted(n) if k.startswith("recon")]
    framesets = s.get("framesets", 0)
    frames = cap.get("frames_in", 0) + cap.get("dropped", 0)
    worst = lambda f: max((f(x) for x in recon), default=float("nan"))
    st = {k: worst(lambda x, k=k: stage(x, k)) for k in ("hull_box", "upload", "visibility", "sweep", "texture", "wait", "image_decode")}
    cst = {k: stage(cap, k) for k in ("lag", "read", "segment", "encode", "publish")}
    sim = n.get("sim", {})
    sim_step, sim_backend = stage(sim, "step"), sim.get("backend", "")
    tmap = worst(lambda x: stage(x, "transport_map", "ms_p95"))
    timg = worst(lambda x: stage(x, "transport_image", "ms_p95"))
    rows.append(f"| {name} | {backend} | {r.get('fps', 0):.1f} | {s['frames_composited']} / {frames} (capture out {cap.get('frames_out', 0)}, {cap.get('fps', 0):.1f} fps) | "
                f"{r.get('latency_ms_p50', 0):.1f} / {r.get('latency_ms_p95', 0):.1f} | "
                f"{st['wait']:.1f} / {st['hull_box']:.1f} / {st['upload']:.1f} / {st['visibility']:.1f} / {st['sweep']:.1f} / {st['texture']:.1f} | "
                f"{tmap:.1f} / {timg:.1f} | {st['image_decode']:.1f} | "
                f"{cst['lag']:.1f} / {cst['read']:.1f} / {cst['segment']:.1f} / {cst['encode']:.1f} / {cst['publish']:.1f} | {sim_step:.1f} | {rc} |")
    summary["runs"][f"{name}_{backend}"] = {"exit": int(rc), "render_fps": r.get("fps"), "composited": s["frames_composited"],
        "frames": frames, "p50_ms": r.get("latency_ms_p50"), "p95_ms": r.get("latency_ms_p95"), "recon_p50_ms": st,
        "transport_map_p95_ms": tmap, "transport_image_p95_ms": timg, "capture_fps": cap.get("fps"),
        "sim_step_p50_ms": sim_step, "sim_backend": sim_backend, "capture_p50_ms": cst}
with open(os.path.join(out, "table.md"), "w") as f:
    f.write(f"GL: {gl_line or 'none'}; {os.cpu_count()} cores\n\n")
    f.write("| run | backend | render fps | composited / frames | p50 / p95 ms | recon p50 ms: wait / hull box / upload / visibility / sweep / texture | transport p95 ms: map / image | recon image decode p50 ms | capture p50 ms: lag / read / segment / encode / publish | sim step p50 ms | exit |\n")
    f.write("|---|---|---|---|---|---|---|---|---|---|---|\n")
    f.write("\n".join(rows) + "\n")
    if not gpu:
        f.write("\nGPU rows not measured: no hardware GL renderer here (the CPU rows only).\n")
    for name in ("bench_gl.md", "bench_cpu_tri.md", "bench_dome.md", "scaling.txt"):
        p = os.path.join(out, name)
        if os.path.exists(p):
            f.write(f"\n{name}:\n\n" + open(p).read())
json.dump(summary, open(os.path.join(out, "summary.json"), "w"), indent=1)
print(open(os.path.join(out, "table.md")).read())
PY
