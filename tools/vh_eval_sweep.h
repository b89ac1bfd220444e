// vh_eval sweep: speed against error of the plane sweep (paper §3.3; docs/benchmarks.md).
#pragma once

#include <string>
#include <vector>

namespace hullpipe {

/// Settings of `vh_eval sweep`.
struct SweepEvalOptions {
  std::string scene = "mixed";    ///< NamedScene name.
  std::string placement = "dome"; ///< dome | ring | rig (the cameras of `rig`).
  std::string rig;                ///< Rig directory or YAML file for placement rig.
  int camera_width = 640, camera_height = 480;  ///< Each synthetic camera's image (--smoke: 320x240).
  double time_s = 0.5;            ///< Scene time.
  int repeats = 3;                ///< Timed runs per configuration (median reported).
  int threads = 1;                ///< CPU sweep threads.
  int threads_reference = 2;      ///< Threads for the exact reference (not timed).
  bool gl = true;                 ///< Include GL rows where an EGL display exists.
  bool full = false;              ///< The full cross product instead of the standard grid.
  bool headline_only = false;     ///< Only the CPU rows at 320x240 with 4 cameras.
  bool smoke = false;             ///< A handful of small rows (seconds), for tests.
  bool json = false;              ///< Print one JSON object instead of a table.
  std::string tsv;                ///< Also write rows as TSV for gnuplot.
};

/// Runs the evaluation, prints JSON or a table; returns the exit code.
int RunSweepEval(const SweepEvalOptions& options);

}  // namespace hullpipe

namespace hullpipe {

/// Settings of `vh_eval texture`: colour error of the textured hull against the
/// synthetic ground truth, with and without the visibility test.
struct TextureEvalOptions {
  std::vector<std::string> scenes = {"mixed", "figure", "hand"};
  std::vector<int> cameras = {4, 8};
  int width = 320, height = 240;  ///< Novel view.
  int threads = 1;
  bool json = false;
};

/// Runs it, prints JSON or a table; returns the exit code.
int RunTextureEval(const TextureEvalOptions& options);

}  // namespace hullpipe
