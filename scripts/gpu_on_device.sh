#!/usr/bin/env bash
# Runs on a lent GPU machine, in the repository's root, what scripts/gpu_carry.sh
# packed (docs/gpu.md, "Measuring a GPU machine in one call"): unpacks the
# bundle and the two real rigs, runs scripts/gpu_scale.sh over them, then the
# GL stages' tests against their CPU references with the time left, and leaves
# in $OUT what comes back (at most 8 files): table.md, summary.json, gl_tests.txt
# and results.tar.gz (every run's stats.json, latency.tsv and logs; no videos).
#
# Usage: bash scripts/gpu_on_device.sh   (OUT: where results go, default out/device)
# Environment: ROWS, BACKENDS, QUICK (passed to gpu_scale.sh), BUDGET_S (the
# call's seconds, default 570), CARRY (default .carry/gpu.tar.xz).
set -uo pipefail
cd "$(dirname "$0")/.."
CARRY="${CARRY:-.carry/gpu.tar.xz}"
OUT="${OUT:-out/device}"
BUDGET_S="${BUDGET_S:-570}"
mkdir -p "$OUT"
[ -f "$CARRY" ] || { echo "gpu_on_device: $CARRY not found: run scripts/gpu_carry.sh and carry .carry" >&2; exit 2; }
HP=/tmp/hullpipe_device
rm -rf "$HP" && mkdir -p "$HP"
if command -v xz > /dev/null; then
  tar -C "$HP" -xJf "$CARRY" || exit 2
else
  python3 -c 'import sys, tarfile; tarfile.open(sys.argv[1]).extractall(sys.argv[2])' "$CARRY" "$HP" || exit 2
fi
HP="$HP/hp"
echo "gpu_on_device: commit $(cat "$HP/COMMIT"), $(nproc) cores, $(uname -r)" >&2
# NVIDIA's EGL vendor file where libglvnd does not look (docs/gpu.md).
nv=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
if [ ! -f /usr/share/glvnd/egl_vendor.d/10_nvidia.json ] && [ -f "$nv" ]; then
  export __EGL_VENDOR_LIBRARY_FILENAMES="$nv"
fi
command -v nvidia-smi > /dev/null && nvidia-smi --query-gpu=name,driver_version --format=csv,noheader >&2
ldconfig -p 2>/dev/null | grep -q 'libEGL.so.1' ||
  echo "gpu_on_device: no libEGL.so.1 here: the GL rows will fail (device/README: carry libglvnd)" >&2

# Work outside $OUT (synthesized rigs, videos): only the results go there.
W=/tmp/hullpipe_device_work
rm -rf "$W" && mkdir -p "$W/scale"
RIG="$HP/rigs/utrecht-4cam" DOME="$HP/rigs/dome-20cam" RIGS="$W/rigs" timeout $((BUDGET_S - 60)) \
  bash scripts/gpu_scale.sh "$HP/bin" "$W/scale" > "$OUT/table.md" 2> "$W/scale/gpu_scale.err"
echo "gpu_on_device: gpu_scale exit $?, ${SECONDS} s in" >&2
cp "$W/scale/summary.json" "$OUT/" 2>/dev/null

# The GL tests read the source tree and the Utrecht rig where the build put
# them; made there (a copy, a link) only where nothing is.
left=$((BUDGET_S - SECONDS - 15))
src="$(cat "$HP/SOURCE_DIR")" rig="$(cat "$HP/RIG_DIR")"
if [ "$left" -gt 30 ]; then
  [ -e "$src" ] || { mkdir -p "$(dirname "$src")" && cp -r "$PWD" "$src"; }
  [ -e "$rig" ] || { mkdir -p "$(dirname "$(realpath -m "$rig")")" && ln -s "$HP/rigs/utrecht-4cam" "$(realpath -m "$rig")"; }
  (cd "$src" && LD_LIBRARY_PATH="$HP/lib" timeout "$left" "$HP/bin/gl_tests" --gtest_brief=1) > "$OUT/gl_tests.txt" 2>&1
  echo "gpu_on_device: gl_tests exit $? (${SECONDS} s in)" | tee -a "$OUT/gl_tests.txt" >&2
else
  echo "gpu_on_device: no time left for gl_tests" | tee "$OUT/gl_tests.txt" >&2
fi
tar -C "$W" -czf "$OUT/results.tar.gz" --exclude='*.mp4' --exclude='*.png' --exclude='*.jpg' scale
ls -la "$OUT" >&2
