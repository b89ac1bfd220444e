#!/usr/bin/env bash
# The sanitizer and fuzzing part of the test command (docs/reliability.md):
#  1. build-asan (clang, AddressSanitizer + UndefinedBehaviorSanitizer, libFuzzer
#     coverage): the core unit tests (label core) and the recording tests that
#     run in one process; then each fuzz target for FUZZ_SECONDS (default 20) on
#     its seeds (scripts/fuzz.sh), after its regression inputs
#     (fuzz/regressions/<target>).
#  2. build-tsan (clang, ThreadSanitizer): the core tests, the recording tests
#     and the nodes' bad-input and SIGINT tests, the nodes built with TSan too.
#
#   bash scripts/sanitize.sh              every stage, one after the other
#   bash scripts/sanitize.sh STAGE ...    only these: build-asan, test-asan,
#                                         fuzz, build-tsan, test-tsan
# scripts/test.sh runs build-asan and build-tsan beside the main suite at idle
# CPU priority, then the others (docs/benchmarks.md, "The whole test command").
# Each test may take 600 s: the longest under ASan+UBSan take ~2 minutes on a
# 2-core machine (docs/benchmarks.md, "Build").
# A finding fails the run: sanitizers abort on the first report
# (-fno-sanitize-recover=all), a fuzzer exits non-zero and leaves its crash file
# in build-asan/fuzz-out/<target>/.
set -euo pipefail
cd "$(dirname "$0")/.."
# Each stage's line says when it starts (CI's whole run has 90 minutes).
stage() { echo "== sanitize: $* ($(date -u +%H:%M:%S), ${SECONDS} s in)"; }
FUZZ_SECONDS="${FUZZ_SECONDS:-20}"
RIG="${RIG:-../shared/data/utrecht-4cam}"
# Warnings are the main (gcc, -Werror) build's business; clang's own extra
# warnings do not stop the sanitizer builds.
CLANG=(-DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 -DCMAKE_BUILD_TYPE=RelWithDebInfo)
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"

CORE_TESTS=(util_tests geometry_tests capture_tests reconstruction_tests collision_tests evaluation_tests segmentation_tests models_tests
            scenes_tests nodes_tests launch_support_tests)
THREADED_CORE_TESTS=(util_tests capture_tests reconstruction_tests collision_tests evaluation_tests segmentation_tests
                     scenes_tests nodes_tests launch_support_tests)  # for TSan: CORE_TESTS but geometry and models
FUZZERS=(fuzz_wire_samples fuzz_map_runs fuzz_rig_files fuzz_scene_files fuzz_csv_files fuzz_recordings fuzz_model_files fuzz_bridge_messages)  # as in scripts/fuzz.sh

build_asan() {
  stage "ASan + UBSan build (clang-14)"
  cmake -S . -B build-asan -G Ninja "${CLANG[@]}" -DHULLPIPE_SANITIZE=address,undefined -DHULLPIPE_FUZZ=ON -DHULLPIPE_WERROR=OFF >/dev/null
  cmake --build build-asan --target "${CORE_TESTS[@]}" record_tests bridge_tests ros2_tests "${FUZZERS[@]}" fuzz_make_seeds
}

test_asan() {
  stage "ASan + UBSan tests"
  # The core tests and the recording, bridge and ROS 2 tests that run in one
  # process (not the tools, the bridges as processes: they are not built here),
  # in one ctest run, so that no long test's tail leaves a core idle between two.
  # Left out too: the exact reprojection at the dome's real size, the longest
  # here (31 s), whose code MatchesRayHullIntervalsPixelByPixel runs on smaller
  # images (the main suite runs both).
  ctest --test-dir build-asan -j2 --output-on-failure --timeout 600 -L 'core|record|bridge' \
      -E '^(RecordTools|Storage/RecordToolsOn|BridgeProcess|Foxglove|Ros2Process|Ros2Export)\.|^ReprojectionExact\.TwentyDistortedCamerasAtTheirRealSize$'
}

fuzz() {
  stage "fuzzing, ${FUZZ_SECONDS} s per target"
  FUZZ_SECONDS="$FUZZ_SECONDS" RIG="$RIG" bash scripts/fuzz.sh
}

# ThreadSanitizer: the core tests of every library that starts threads (row-band
# threads, the rig source's parallel reads, read-ahead and live readers, the
# sweep, the controllers; not geometry_tests and models_tests: those libraries
# start none, and ASan+UBSan runs them), the recording tests (the
# recorder and the player with their threads) and the nodes' bad-input and
# SIGINT tests, each node process built with TSan too. Third-party libraries
# not built with TSan are suppressed by name in scripts/tsan.supp, each with
# its reason. The DDS layer's tests (dds_tests: the nodes' input thread) run
# here too. HULLPIPE_TEST_TIME_SCALE=4 relaxes the tests' timing bounds (TSan
# slows every process 5-15 fold; the main suite checks the specified bounds).
# Left out: ReplayingTwiceIntoSimNode..., whose sim_node must keep up with a
# 25-fps replay (17 of 50 frames under TSan); and what repeats threaded code
# another test here runs, only longer (TSan tests run both cores full, so each
# second of CPU left out is half a second of the whole command's; docs/
# benchmarks.md, "The whole test command"): capture on the whole videos and on
# a truncated one (EveryVideoTruncatedAlike, ACameraWithNoFrames and
# GarbageVideo run the same capture threads), the whole-pipeline replay (the
# recorder's and replayer's threads are Storage/RecordToolsOn's), the exact
# reprojection at the dome's real size (MatchesRayHullIntervalsPixelByPixel runs
# its threads), four single-threaded exactness tests (a skewed rig's exact
# hull, the ring's hull box, the sweep's hit bounds and its background runs
# against a sweep without them), and node_bench on a stereo recording (the
# recon, render and capture processes NodeTest runs). HULLPIPE_TSAN=0 skips
# the stage.
build_tsan() {
  stage "TSan build (clang-14)"
  cmake -S . -B build-tsan -G Ninja "${CLANG[@]}" -DHULLPIPE_SANITIZE=thread -DHULLPIPE_WERROR=OFF >/dev/null
  cmake --build build-tsan --target "${THREADED_CORE_TESTS[@]}" dds_tests record_tests node_tests hullpipe_record hullpipe_replay \
      hullpipe_cmd capture_node recon_node sim_node render_node
}

test_tsan() {
  stage "TSan tests"
  export TSAN_OPTIONS="${TSAN_OPTIONS:-halt_on_error=1:second_deadlock_stack=1:suppressions=$PWD/scripts/tsan.supp}"
  export HULLPIPE_TEST_TIME_SCALE=4
  # (Not under TSan: the sim replay twice and the rig demo read by the npm readers,
  # whole pipelines that only time out at TSan's speed.)
  # (Label nodes: NodeTest and CaptureFiles; the fuzz and security tests are
  # not built here, so their placeholders carry no label.) One ctest run, as above.
  local left_out=(ReplayingTwiceIntoSimNodeGivesIdenticalCollisionReports TheRigsDemoAsMcapOpensInTheFieldsOwnReaders
                  CaptureFiles.TheWholeVideoEndsWithExit0 CaptureFiles.TruncatedVideoEndsTheInputThereWithExit3
                  RecordTools.AWholeRecordingReplayedIntoALiveRunIsNotMixedIn
                  ReprojectionExact.TwentyDistortedCamerasAtTheirRealSize
                  ExactHull.ASkewedRigHasTheHullOfTheSameRigResampledWithoutSkew
                  HullBox.TightToTheHullsOwnBoxOnARingAndConservative
                  HitBounds.PointsWhereNoHitCanBeAreSkippedChangingNoPixel BackgroundRuns.SkippedRunsChangeNoPixel
                  TheReconBenchAnswersBothEyesOfAStereoRecordingOrTheFirstAlone)
  ctest --test-dir build-tsan -j2 --output-on-failure --timeout 600 -L 'core|dds|record|nodes' \
      -E "$(IFS='|'; echo "${left_out[*]}")"
}

stages=("$@")
if [ ${#stages[@]} -eq 0 ]; then
  stages=(build-asan test-asan fuzz build-tsan test-tsan)
fi
for s in "${stages[@]}"; do
  case "$s" in
    build-asan) build_asan ;;
    test-asan) test_asan ;;
    fuzz) fuzz ;;
    build-tsan|test-tsan)
      if [ "${HULLPIPE_TSAN:-1}" = 0 ]; then
        stage "$s skipped: HULLPIPE_TSAN=0"
      elif [ "$s" = build-tsan ]; then build_tsan; else test_tsan; fi ;;
    *) echo "sanitize.sh: unknown stage '$s' (build-asan, test-asan, fuzz, build-tsan, test-tsan)" >&2; exit 2 ;;
  esac
done
[ $# -eq 0 ] && stage "clean"
exit 0
