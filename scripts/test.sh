#!/usr/bin/env bash
# README command (2): install what is needed, build, and run every test.
# Labels: core, gl (skips with a message where no EGL display exists), dds,
# nodes (node processes fed bad input), e2e (the five processes on the real rig).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
echo "== test: build ($(date -u +%H:%M:%S))"
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build

# The whole run (no ctest arguments) goes on to the sanitizer builds, their
# tests and the fuzz targets (scripts/sanitize.sh, docs/reliability.md);
# HULLPIPE_SANITIZE=0 skips them.
whole=0
if [ $# -eq 0 ] && [ "${HULLPIPE_SANITIZE:-1}" != 0 ]; then whole=1; fi
declare -A bg=()
if [ "$whole" = 1 ]; then
  # The two sanitizer trees compile while the main suite runs, at idle CPU
  # priority (SCHED_IDLE, else nice 19): they take only what the suite leaves
  # idle (about 40% of two cores: its multi-process tests wait on their
  # timelines), so the suite's timing is as when it runs alone
  # (docs/benchmarks.md, "The whole test command"). Each build runs in its own
  # process group, stopped with its compilers if this script ends first.
  idle=(nice -n 19)
  chrt -i 0 true 2>/dev/null && idle=(chrt -i 0)
  set -m
  for b in build-asan build-tsan; do
    "${idle[@]}" bash scripts/sanitize.sh "$b" >"build/sanitize-$b.log" 2>&1 &
    bg[$b]=$!
  done
  set +m
  trap 'for p in "${bg[@]}"; do kill -- "-$p" 2>/dev/null || true; done' EXIT
fi

echo "== test: ctest ($(date -u +%H:%M:%S), ${SECONDS} s in)"
ctest --test-dir build -j2 --output-on-failure --timeout 300 "$@"
[ "$whole" = 1 ] || exit 0

# await <build>: waits for a sanitizer build started above; its log's last
# lines on failure.
await() {
  echo "== test: waiting for $1 ($(date -u +%H:%M:%S), ${SECONDS} s in)"
  if ! wait "${bg[$1]}"; then
    tail -60 "build/sanitize-$1.log" >&2
    echo "test.sh: $1 failed (whole log: build/sanitize-$1.log)" >&2
    exit 1
  fi
  unset "bg[$1]"
  grep '^== sanitize' "build/sanitize-$1.log" || true
  echo "== test: $1 done ($(date -u +%H:%M:%S), ${SECONDS} s in)"
}
await build-asan
bash scripts/sanitize.sh test-asan fuzz
await build-tsan
bash scripts/sanitize.sh test-tsan
echo "== test: clean ($(date -u +%H:%M:%S), ${SECONDS} s in)"
