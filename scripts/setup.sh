#!/usr/bin/env bash
# Installs every Debian 12 package hullpipe needs to build, test and run.
# Idempotent: when everything is present it prints nothing and touches nothing.
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build pkg-config git
  cyclonedds-dev cyclonedds-tools
  libopencv-dev libeigen3-dev
  libegl-dev libgles-dev libgl-dev libgbm-dev libegl-mesa0 libgl1-mesa-dri
  libgtest-dev libgmock-dev libbenchmark-dev
  libcli11-dev libspdlog-dev nlohmann-json3-dev libyaml-cpp-dev libsqlite3-dev libxml2-dev libzstd-dev liblz4-dev
  libwebsocketpp-dev libasio-dev
  libassimp-dev assimp-testmodels
  libopenxr-dev
  ffmpeg gnuplot-nox openssl iproute2 iceoryx linux-perf
  clang-14 libclang-rt-14-dev llvm-14
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
# The field's own MCAP and Foxglove readers that the interoperability tests run
# (tests/js/package.json, pinned by its lock file), from the npm registry into the
# ignored tests/js/node_modules.
install_npm_readers() {
  local js
  js="$(cd "$(dirname "$0")/.." && pwd)/tests/js"
  if [ ! -f "$js/node_modules/.package-lock.json" ] || ! cmp -s "$js/package-lock.json" "$js/node_modules/.hullpipe-lock"; then
    echo "hullpipe setup: installing the npm readers in tests/js" >&2
    (cd "$js" && npm ci --no-audit --no-fund --loglevel=error >/dev/null && cp package-lock.json node_modules/.hullpipe-lock)
  fi
}

if [ ${#missing[@]} -eq 0 ]; then
  install_npm_readers
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "hullpipe setup: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
install_npm_readers
