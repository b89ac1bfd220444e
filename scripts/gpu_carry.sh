#!/usr/bin/env bash
# Packs what a GPU machine without Debian's packages needs to be measured in
# one call (docs/gpu.md, "Measuring a GPU machine in one call"):
# this build's binaries with their libraries (scripts/bundle_binaries.py), the
# Utrecht rig and the published dome, as one xz archive in an ignored folder
# that the device's `run` carries. The whole working tree that travels must
# stay under 64 MiB; the bundle alone is ~87 MiB, the archive with both rigs ~42.
#
# Usage: scripts/gpu_carry.sh [BUILD_DIR]   (default build)
#   writes .carry/gpu.tar.xz and prints the call to make:
#   run(command="bash scripts/gpu_on_device.sh", carry=[".carry"], timeout_s=600)
# Environment: RIG, DOME (defaults ../shared/data/utrecht-4cam and
# ../shared/data/dome-20cam), LIMIT_MIB (default 64).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD="${1:-build}"
RIG="${RIG:-../shared/data/utrecht-4cam}"
DOME="${DOME:-../shared/data/dome-20cam}"
LIMIT_MIB="${LIMIT_MIB:-64}"
# gpu_scale.sh's binaries, and the GL stages' tests against their CPU references.
EXES=(hullpipe_bench scaling_bench hullpipe_rig hullpipe_launch capture_node recon_node sim_node render_node gl_tests)
for e in "${EXES[@]}"; do
  [ -x "$BUILD/bin/$e" ] || { echo "gpu_carry: $BUILD/bin/$e missing (build it first)" >&2; exit 2; }
done
for d in "$RIG/cam1/config.xml" "$DOME/rig.yaml"; do
  [ -f "$d" ] || { echo "gpu_carry: $d not found" >&2; exit 2; }
done
grep -qx '/.carry/' .gitignore || { echo "gpu_carry: .gitignore must ignore /.carry/" >&2; exit 2; }

stage="$(mktemp -d)"
trap 'rm -rf "$stage"' EXIT
python3 scripts/bundle_binaries.py "$stage/hp" "${EXES[@]/#/$BUILD/bin/}" >&2
mkdir -p "$stage/hp/rigs"
cp -r "$RIG" "$stage/hp/rigs/utrecht-4cam"
cp -r "$DOME" "$stage/hp/rigs/dome-20cam"
chmod -R u+w "$stage/hp"
git rev-parse HEAD > "$stage/hp/COMMIT"
# Where the tests look for the source tree and the rig (compiled in).
sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$BUILD/CMakeCache.txt" > "$stage/hp/SOURCE_DIR"
sed -n 's/^HULLPIPE_RIG_DIR:PATH=//p' "$BUILD/CMakeCache.txt" > "$stage/hp/RIG_DIR"
mkdir -p .carry
rm -f .carry/gpu.tar.xz
tar -C "$stage" -cf - hp | xz -9 -T2 > .carry/gpu.tar.xz

# What travels: tracked files, untracked files git does not ignore, and .carry.
travel=$( { git ls-files -z --cached --others --exclude-standard | xargs -0 -r stat -c %s -- 2>/dev/null;
            find .carry -type f -printf '%s\n'; } | awk '{s += $1} END {print s + 0}')
mib=$(( (travel + 1048575) / 1048576 ))
echo "gpu_carry: .carry/gpu.tar.xz $(( $(stat -c %s .carry/gpu.tar.xz) / 1048576 )) MiB;" \
     "the working tree with it ${mib} MiB of ${LIMIT_MIB}" >&2
if [ "$mib" -gt "$LIMIT_MIB" ]; then
  echo "gpu_carry: over the ${LIMIT_MIB} MiB a device call carries" >&2
  exit 1
fi
echo 'run(command="bash scripts/gpu_on_device.sh", carry=[".carry"], timeout_s=600)'
