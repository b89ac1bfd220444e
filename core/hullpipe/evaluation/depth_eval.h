// Depth images compared against a reference (the exact hull, or the true shapes
// of a synthetic scene): the error metrics of `vh_eval sweep` (paper §3.3; docs/benchmarks.md).
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/evaluation/synthetic.h"

namespace hullpipe {

/// How a depth image differs from a reference of the same view.
struct DepthComparison {
  int64_t both = 0;      ///< Pixels with a finite depth in both.
  int64_t only_got = 0;  ///< Finite in the image, +inf (no hull) in the reference.
  int64_t only_ref = 0;  ///< +inf in the image, finite in the reference.
  /// |got - ref| over `both` pixels, millimetres (depth is eye z).
  double err_mm_median = 0, err_mm_p95 = 0, err_mm_max = 0;
  /// Signed (got - ref) median over `both`, mm: > 0 means behind the reference.
  double signed_mm_median = 0;
  /// only_got and only_ref as fractions of the pixels finite in either image.
  double wrong_inside = 0, wrong_outside = 0;
};

/// Compares two CV_32FC1 depth images of one size (+inf = nothing there). NaN
/// counts as +inf. Throws std::invalid_argument on a type or size mismatch.
DepthComparison CompareDepth(const cv::Mat& got, const cv::Mat& ref);

/// The true eye-z depth of the scene's shapes for every pixel of the view
/// (CV_32FC1, +inf where the pixel's centre ray misses every shape).
cv::Mat SceneDepth(const SyntheticScene& scene, const NovelView& view);

}  // namespace hullpipe
