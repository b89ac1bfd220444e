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
echo "== test: ctest ($(date -u +%H:%M:%S), ${SECONDS} s in)"
ctest --test-dir build -j2 --output-on-failure --timeout 300 "$@"
# The whole run (no ctest arguments) goes on to the sanitizer builds and the
# fuzz targets (docs/reliability.md); HULLPIPE_SANITIZE=0 skips them.
if [ $# -eq 0 ] && [ "${HULLPIPE_SANITIZE:-1}" != 0 ]; then
  bash scripts/sanitize.sh
fi
