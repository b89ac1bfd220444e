#!/usr/bin/env bash
# The demo on a rig other than the Utrecht one (docs/rigs.md, "Another rig"),
# the way a lab brings a COLMAP-calibrated rig: `hullpipe_rig synthesize`
# films the synthetic figure with 8 cameras on a ring (videos) and writes their
# calibration as a COLMAP text model in a z-up world of its own; the model is
# imported and checked, and the five processes run on it with the demo scene.
# Writes under ${OUT:-out_other_rig}: rig/ (videos, sparse/0, rig.yaml) and the
# run's outputs as scripts/demo.sh writes them. Extra arguments go to
# hullpipe_launch (e.g. --frames 100, --orbit-radius 3.5).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build
OUT="${OUT:-out_other_rig}"
RIG="$OUT/rig"
if [[ ! -f "$RIG/sparse/0/images.txt" ]]; then
  ./build/bin/hullpipe_rig synthesize -o "$RIG" --cameras 8 --size 480x360 --frames 250 --fps 25
fi
./build/bin/hullpipe_rig import --from colmap "$RIG/sparse/0" -o "$RIG/rig.yaml" \
    --frames 'videos/cam{id}.avi' --background 'videos/cam{id}_background.avi'
exec ./build/bin/hullpipe_launch --rig "$RIG/rig.yaml" --out "$OUT" "$@"
