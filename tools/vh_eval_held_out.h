// vh_eval held-out and segmentation: the rendering error on a real rig, each
// camera held out in turn (evaluation/held_out_rendering.h; docs/benchmarks.md,
// "Held-out rendering" and "Segmentation settings").
#pragma once

#include <string>
#include <vector>

namespace hullpipe {

/// Settings shared by `vh_eval held-out` and `vh_eval segmentation`.
struct HeldOutEvalOptions {
  std::string rig;          ///< Rig directory or YAML rig file.
  int stride = 25;          ///< Evaluate frames first, first + stride, ... (>= 1).
  int first = 0;            ///< First frame evaluated (0-based).
  int max_frames = 0;       ///< Evaluate at most this many frames (0: to the end).
  int threads = 2;          ///< Sweep and texture threads.
  bool json = false;        ///< Print one JSON object instead of tables.
  /// held-out: write one JPEG (held_out_frame<K>.jpg) per evaluated frame listed in image_frames into this
  /// directory: a row per held-out camera, the real image then each variant,
  /// cropped to the object.
  std::string images_dir;
  std::vector<int> image_frames;
};

/// Texturing variants (nearest camera, blended, each with and without the
/// visibility test), every camera held out on every evaluated frame: PSNR, SSIM
/// and silhouette IoU per variant and camera. Returns the exit code.
int RunHeldOutEval(const HeldOutEvalOptions& options);

/// Segmentation settings and the adaptive background model: the same measure
/// with the recon node's texturing, one row per setting. Returns the exit code.
int RunSegmentationEval(const HeldOutEvalOptions& options);

}  // namespace hullpipe
