// vh_eval run: a pipeline run's composited hull against the same frames'
// hull computed here. For each frame render_node saved (--save-depth:
// views.csv and frame_NNNNN_depth.tiff), the rig's maps of that frame (the
// rig segmented as capture_node segments it) give a VolumeQuery; the run's
// depth is compared pixel for pixel with the direct plane sweep (the recon
// nodes' settings) and, on every --exact-stride-th pixel, with the exact
// ray–hull intervals (evaluation/run_check.h).
#pragma once

#include <string>

#include <CLI/CLI.hpp>

namespace hullpipe {

struct RunEvalOptions {
  std::string rig;         ///< The rig the run read (directory or YAML rig file).
  std::string run;         ///< The run's --out directory.
  int max_frames = 0;      ///< At most this many of views.csv's frames (0: all).
  int planes = 50;         ///< recon_node --planes.
  int refine = 6;          ///< recon_node --refine.
  std::string out_of_view = "unknown";  ///< recon_node --out-of-view.
  int exact_stride = 4;    ///< The exact intervals at every N-th pixel in x and y.
  int threads = 2;
  bool json = false;       ///< One JSON object on stdout.
  /// A stereo run's eye (render_node --stereo): "left" (views.csv, the frames'
  /// depths) or "right" (views_right.csv, frame_N_right_depth.tiff).
  std::string eye = "left";
};

/// Registers the subcommand's flags on `sub`, into `options`.
void AddRunEvalOptions(CLI::App* sub, RunEvalOptions& options);

/// Runs it: a row per frame and the totals on stdout (or JSON); returns the
/// exit code (0; 1 when a frame's depth is missing or unreadable). Throws
/// std::runtime_error / std::invalid_argument naming the bad file or flag.
int RunRunEval(const RunEvalOptions& options);

}  // namespace hullpipe
