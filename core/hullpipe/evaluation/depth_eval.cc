#include "hullpipe/evaluation/depth_eval.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/util/percentile.h"

namespace hullpipe {

DepthComparison CompareDepth(const cv::Mat& got, const cv::Mat& ref) {
  if (got.type() != CV_32FC1 || ref.type() != CV_32FC1 || got.size() != ref.size())
    throw std::invalid_argument("CompareDepth: two CV_32FC1 images of one size are needed");
  DepthComparison c;
  std::vector<double> abs_err, signed_err;
  for (int r = 0; r < got.rows; ++r) {
    const float* g = got.ptr<float>(r);
    const float* f = ref.ptr<float>(r);
    for (int k = 0; k < got.cols; ++k) {
      const bool a = std::isfinite(g[k]), b = std::isfinite(f[k]);
      if (a && b) {
        ++c.both;
        signed_err.push_back(1e3 * (double(g[k]) - double(f[k])));
        abs_err.push_back(std::abs(signed_err.back()));
      } else if (a) {
        ++c.only_got;
      } else if (b) {
        ++c.only_ref;
      }
    }
  }
  c.err_mm_median = Median(abs_err);
  c.err_mm_p95 = Percentile(abs_err, 95);
  c.err_mm_max = abs_err.empty() ? 0 : *std::max_element(abs_err.begin(), abs_err.end());
  c.signed_mm_median = Median(signed_err);
  const double either = double(c.both + c.only_got + c.only_ref);
  if (either > 0) {
    c.wrong_inside = double(c.only_got) / either;
    c.wrong_outside = double(c.only_ref) / either;
  }
  return c;
}

cv::Mat SceneDepth(const SyntheticScene& scene, const NovelView& view) {
  cv::Mat out(view.height, view.width, CV_32FC1, cv::Scalar(kNoDepth));
  const Eigen::Vector3d O = view.world_from_eye.translation;
  for (int r = 0; r < view.height; ++r)
    for (int c = 0; c < view.width; ++c) {
      const Eigen::Vector3d D = view.world_from_eye.rotation * view.EyeRay(c + 0.5, r + 0.5);
      if (const auto hit = scene.Intersect(O, D)) out.at<float>(r, c) = float(hit->first);  // D has eye z = 1
    }
  return out;
}

}  // namespace hullpipe
