// vh_eval collision: speed against error of collision detection and response
// (paper §4), on synthetic scenes with exact object-pixel maps.
#pragma once

#include <string>
#include <vector>

namespace hullpipe {

/// Settings of `vh_eval collision`.
struct CollisionEvalOptions {
  std::vector<std::string> scenes = {"sphere", "box", "torus"};  ///< NamedScene names (the real objects).
  int cases_per_scene = 24;       ///< Virtual boxes pushed into each scene's hull.
  int cameras = 4;                ///< Dome cameras (the paper had 4).
  int camera_width = 640, camera_height = 480;
  double reference_spacing = 5e-5;  ///< Line spacing of the exact contact region (metres).
  int repeats = 3;                ///< Timed runs of each detection (median).
  bool gl = true;                 ///< Include GL rows where an EGL display exists.
  bool smoke = false;             ///< One scene, few cases, small cameras, CPU only (seconds; for tests).
  bool json = false;              ///< One JSON object instead of a table.
  std::string tsv;                ///< Also write the rows as TSV (for gnuplot).
  unsigned seed = 1;              ///< Case generator seed.
  int normal_fit_radius_px = -1;  ///< HullNormalOptions::fit_radius_px of the exact method (-1: default).
};

/// Runs the evaluation, prints JSON or a table; returns the exit code.
int RunCollisionEval(const CollisionEvalOptions& options);

}  // namespace hullpipe
