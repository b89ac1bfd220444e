// A pipeline run's composited hull checked against the direct computation of
// the same frames: what render_node wrote with --save-depth (views.csv and
// frame_NNNNN_depth.tiff) against the plane sweep of that frame's maps run
// directly (paper §3.3, the recon nodes' settings) and against the exact
// ray–hull intervals (the reference of docs/benchmarks.md, "Reconstruction
// against the exact hull"). `vh_eval run` and the end-to-end tests use it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/evaluation/depth_eval.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe {

/// One row of a run's views.csv (render_node --save-depth, docs/recording.md):
/// the composited frame's frameset and the view it was seen from.
struct RunView {
  uint64_t frame_seq = 0;   ///< The frameset's sequence number (capture's frame index + 1).
  double path_time_s = 0;   ///< Time along the viewpoint's path, seconds.
  NovelView view;           ///< Size, intrinsics (pixel centres at +0.5), world_from_eye.
};

/// Reads views.csv. Throws std::runtime_error naming the file (and the line)
/// if it cannot be read, its header is not render_node's, or a row is not 20
/// finite numbers with a valid view (NovelView::Check, a rotation).
std::vector<RunView> ReadRunViews(const std::string& csv_path);

/// The path render_node writes a frame's depth to: DIR/frame_%05llu_depth.tiff,
/// or with `right` (render_node --stereo: the right eye's, whose views are in
/// views_right.csv) DIR/frame_%05llu_right_depth.tiff.
std::string RunDepthPath(const std::string& run_dir, uint64_t frame_seq, bool right = false);

/// How the recon nodes swept (their flags' defaults: 50 planes, 6 bisections),
/// and how much of the exact reference to compute.
struct RunCheckOptions {
  PlaneSweepOptions sweep;
  int refine = 6;
  /// The exact intervals at every exact_stride-th pixel in x and y (>= 1): they
  /// cost ~8 ms a ray through 20 distorted cameras.
  int exact_stride = 1;
  int threads = 1;
  /// Throws std::invalid_argument naming the bad field.
  void Check() const;
};

/// One frame's result.
struct RunFrameCheck {
  int64_t pixels = 0;          ///< The view's pixels.
  int64_t equal_to_sweep = 0;  ///< Pixels whose depth equals the direct sweep's exactly (both +inf counts).
  int64_t hull_pixels = 0;     ///< Pixels with hull in the run's depth.
  DepthComparison exact;       ///< The run's depth against the exact intervals, on the stride's pixels.
  int64_t exact_pixels = 0;    ///< Pixels the exact reference was computed at.
  double seconds = 0;          ///< The check's own time.
};

/// Compares `depth` (CV_32FC1 eye z in metres, +inf where no hull: a run's
/// frame_NNNNN_depth.tiff) with the direct sweep of `query` from `view` over
/// the whole view and with the exact hull on the stride's pixels. Throws
/// std::invalid_argument if depth is not CV_32FC1 of the view's size.
RunFrameCheck CheckRunFrame(const VolumeQuery& query, const NovelView& view, const cv::Mat& depth,
                            const RunCheckOptions& options);

}  // namespace hullpipe
