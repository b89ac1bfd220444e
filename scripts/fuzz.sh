#!/usr/bin/env bash
# Runs hullpipe's libFuzzer targets (docs/reliability.md, "Fuzzing and
# sanitizers") from an existing build-asan (scripts/sanitize.sh makes it):
#   FUZZ_SECONDS=600 FUZZ_JOBS=1 bash scripts/fuzz.sh [target ...]
# Each target first runs its regression inputs (fuzz/regressions/<target>, in
# git: what once failed), then fuzzes from its seeds: the rig's config.xml
# files, the launch YAMLs, the shipped scenes and CSVs, and one valid sample of
# every topic and a small recording (fuzz_make_seeds), FUZZ_JOBS targets at a
# time (default: the cores). A fixed -seed keeps CI's short runs repeatable. Per target
# it prints the executions, the peak RSS and the corpus it grew; a finding exits
# 1 naming the crash file left in build-asan/fuzz-out/<target>/.
set -euo pipefail
cd "$(dirname "$0")/.."
FUZZ_SECONDS="${FUZZ_SECONDS:-20}"
RIG="${RIG:-../shared/data/utrecht-4cam}"
BIN=build-asan/bin
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
FUZZERS=(fuzz_wire_samples fuzz_map_runs fuzz_rig_files fuzz_scene_files fuzz_csv_files fuzz_recordings fuzz_model_files fuzz_bridge_messages)
[ $# -gt 0 ] && FUZZERS=("$@")
for f in "${FUZZERS[@]}" fuzz_make_seeds; do
  [ -x "$BIN/$f" ] || { echo "fuzz.sh: $BIN/$f is missing; run scripts/sanitize.sh first" >&2; exit 1; }
done

SEEDS=build-asan/fuzz-seeds
rm -rf "$SEEDS" && mkdir -p "$SEEDS"
"$BIN/fuzz_make_seeds" "$SEEDS"
mkdir -p "$SEEDS/fuzz_rig_files" "$SEEDS/fuzz_scene_files" "$SEEDS/fuzz_csv_files"
# The rig parser's first byte picks config.xml (0), a YAML rig (1) or an OpenCV
# calibration for the importer (2).
for cfg in "$RIG"/cam*/config.xml; do
  [ -f "$cfg" ] && { printf '\x00'; cat "$cfg"; } > "$SEEDS/fuzz_rig_files/$(basename "$(dirname "$cfg")").xml"
done
for yml in launch/*.yaml; do { printf '\x01'; cat "$yml"; } > "$SEEDS/fuzz_rig_files/$(basename "$yml")"; done
for cal in fuzz/seeds/opencv_calibration/*; do { printf '\x02'; cat "$cal"; } > "$SEEDS/fuzz_rig_files/$(basename "$cal")"; done
cp scenes/*.yaml "$SEEDS/fuzz_scene_files/"
for csv in scenes/*.csv; do
  { printf '\x00'; cat "$csv"; } > "$SEEDS/fuzz_csv_files/pose_$(basename "$csv")"
  { printf '\x01'; cat "$csv"; } > "$SEEDS/fuzz_csv_files/motion_$(basename "$csv")"
  { printf '\x02'; cat "$csv"; } > "$SEEDS/fuzz_csv_files/eyes_$(basename "$csv")"
done

# Model files: the first byte picks the format (fuzz_model_files.cc); small
# samples from Debian's assimp-testmodels.
mkdir -p "$SEEDS/fuzz_model_files"
M=/usr/share/assimp/models
seed_model() {  # seed_model <format byte> <file>
  [ -f "$2" ] && [ "$(stat -c %s "$2")" -le 60000 ] && { printf "\\x$1"; cat "$2"; } > "$SEEDS/fuzz_model_files/$1_$(basename "$2")"
  return 0
}
seed_model 00 "$M/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb"
seed_model 01 "$M/glTF2/BoxTextured-glTF-Embedded/BoxTextured.gltf"
seed_model 02 "$M/OBJ/box.obj"
seed_model 02 "$M/OBJ/testmixed.obj"
seed_model 03 "$M/STL/Spider_ascii.stl"
seed_model 04 "$M/PLY/cube.ply"
seed_model 05 "$M/OFF/Cube.off"

# A client's text messages (fuzz_bridge_messages: NUL between messages).
mkdir -p "$SEEDS/fuzz_bridge_messages"
printf '%s\0%s\0%s' '{"op":"subscribe","subscriptions":[{"id":1,"channelId":2},{"id":2,"channelId":2}]}' \
  '{"op":"unsubscribe","subscriptionIds":[1]}' '{"op":"advertise","channels":[]}' > "$SEEDS/fuzz_bridge_messages/subscribe"
printf '%s' '{"op":"subscribe","subscriptions":[{"id":4294967296,"channelId":4294967298}],"x":[[[["]]"]]]]}' \
  > "$SEEDS/fuzz_bridge_messages/ids"

# Regression inputs (fuzz/regressions/<target>): each once, before fuzzing.
# They are not seeds: the 201-Mpixel map that timed out would slow every
# mutation made from it.
for f in "${FUZZERS[@]}"; do
  if compgen -G "fuzz/regressions/$f/*" >/dev/null; then
    if ! "$BIN/$f" -timeout=10 -rss_limit_mb=2048 fuzz/regressions/"$f"/* >"build-asan/fuzz-regressions-$f.log" 2>&1; then
      tail -40 "build-asan/fuzz-regressions-$f.log" >&2
      echo "fuzz.sh: $f fails on a regression input in fuzz/regressions/$f" >&2
      exit 1
    fi
    echo "$f: $(ls fuzz/regressions/"$f" | wc -l) regression input(s) pass"
  fi
done

# fuzz_one <target>: FUZZ_SECONDS of fuzzing from the seeds; prints one line,
# returns non-zero on a finding (its log's tail on stderr).
fuzz_one() {
  local f="$1" work="build-asan/fuzz-out/$1" extra=""
  rm -rf "$work" && mkdir -p "$work/corpus"
  local dirs=("$work/corpus" "$SEEDS/$f")
  # The model importer's child may ask for gigabytes (that is what it is
  # bounded for): under ASan the allocation fails instead of the machine.
  [ "$f" = fuzz_model_files ] && extra=":allocator_may_return_null=1:max_allocation_size_mb=1024"
  if ! (cd "$work" && ASAN_OPTIONS="$ASAN_OPTIONS$extra" "$OLDPWD/$BIN/$f" -seed=1 -max_total_time="$FUZZ_SECONDS" -rss_limit_mb=2048 -timeout=10 \
          -max_len=65536 -print_final_stats=1 "${dirs[@]/#/$OLDPWD/}" >fuzz.log 2>&1); then
    tail -40 "$work/fuzz.log" >&2
    echo "fuzz.sh: $f found a failing input: $(ls "$work"/crash-* "$work"/leak-* "$work"/timeout-* "$work"/oom-* 2>/dev/null | head -3)" >&2
    return 1
  fi
  local execs rss
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/fuzz.log")
  rss=$(sed -n 's/^stat::peak_rss_mb: *//p' "$work/fuzz.log")
  echo "$f: ${execs:-?} executions in ${FUZZ_SECONDS} s, peak RSS ${rss:-?} MB, corpus $(ls "$work/corpus" | wc -l) inputs grown, no finding"
}

# Each libFuzzer process is one thread: FUZZ_JOBS targets (default: the
# cores) fuzz at once, each still for its FUZZ_SECONDS.
FUZZ_JOBS="${FUZZ_JOBS:-$(nproc)}"
echo "-- ${#FUZZERS[@]} target(s), ${FUZZ_SECONDS} s each, ${FUZZ_JOBS} at a time"
failed=0
running=0
for f in "${FUZZERS[@]}"; do
  if [ "$running" -ge "$FUZZ_JOBS" ]; then
    wait -n || failed=1
    running=$((running - 1))
  fi
  fuzz_one "$f" &
  running=$((running + 1))
done
while [ "$running" -gt 0 ]; do
  wait -n || failed=1
  running=$((running - 1))
done
exit "$failed"
