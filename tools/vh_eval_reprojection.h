// vh_eval reprojection: per camera, the IoU between the hull's reprojection
// into the camera and its object-pixel map, with the hull of all cameras and of
// the others only (leave one out); exact (ExactReprojector, ray–hull intervals)
// or marched; one frame, every frame, or a synthetic dome for timing
// (evaluation/reprojection.h).
#pragma once

#include <string>

#include <CLI/CLI.hpp>

namespace hullpipe {

struct ReprojectionEvalOptions {
  std::string rig;          ///< Rig directory or YAML rig file.
  int frame = 200;          ///< Frame index (0-based) unless all_frames.
  bool all_frames = false;  ///< Every frame: mean and worst per camera.
  bool json = false;        ///< One JSON object on stdout.
  std::string save_worst;   ///< With all_frames: PNG of the worst frame's reprojections.
  int synthetic = 0;        ///< Instead of a rig: a synthetic figure seen by N dome cameras.
  int width = 1024, height = 768;  ///< The synthetic cameras' size.
  std::string method = "exact";    ///< exact or march.
  double step = 0.005;      ///< march: the ray-marching step, metres.
  int threads = 2;
};

/// Registers the subcommand's flags on `sub`, into `options`.
void AddReprojectionOptions(CLI::App* sub, ReprojectionEvalOptions& options);

/// Runs it: the table (or JSON) on stdout; returns the exit code. Throws
/// std::runtime_error / std::invalid_argument naming the bad input.
int RunReprojectionEval(const ReprojectionEvalOptions& options);

}  // namespace hullpipe
