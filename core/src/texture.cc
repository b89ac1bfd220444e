#include "hullpipe/texture.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "hullpipe/conventions.h"

namespace hullpipe {

void TextureOptions::Check() const {
  if (max_cameras < 1) throw std::invalid_argument("TextureOptions: max_cameras must be >= 1");
  if (!(angle_power >= 0)) throw std::invalid_argument("TextureOptions: angle_power must be >= 0");
}

namespace {
cv::Vec3f Bilinear(const cv::Mat& img, double u, double v) {
  // Continuous coords with centres at +0.5 -> sample grid.
  const double x = std::clamp(u - 0.5, 0.0, img.cols - 1.0), y = std::clamp(v - 0.5, 0.0, img.rows - 1.0);
  const int x0 = int(x), y0 = int(y);
  const int x1 = std::min(x0 + 1, img.cols - 1), y1 = std::min(y0 + 1, img.rows - 1);
  const float ax = float(x - x0), ay = float(y - y0);
  const cv::Vec3f p00 = img.at<cv::Vec3b>(y0, x0), p01 = img.at<cv::Vec3b>(y0, x1);
  const cv::Vec3f p10 = img.at<cv::Vec3b>(y1, x0), p11 = img.at<cv::Vec3b>(y1, x1);
  return (p00 * (1 - ax) + p01 * ax) * (1 - ay) + (p10 * (1 - ax) + p11 * ax) * ay;
}
}  // namespace

cv::Mat TextureHull(const cv::Mat& depth, const cv::Rect& tile, const NovelView& view,
                    const std::vector<CameraImage>& images, const TextureOptions& options) {
  options.Check();
  CV_Assert(depth.type() == CV_32FC1 && depth.size() == tile.size());
  cv::Mat out(tile.size(), CV_8UC3, cv::Scalar(0, 0, 0));
  std::vector<Camera> cams;
  std::vector<Eigen::Vector3d> centres;
  for (const auto& ci : images) {
    cams.push_back(ScaledCamera(ci.camera, ci.image.cols, ci.image.rows));
    centres.push_back(cams.back().Center());
  }
  const Eigen::Vector3d O = view.world_from_eye.translation;
  const Eigen::Matrix3d& R = view.world_from_eye.rotation;
  struct Candidate {
    double weight;
    cv::Vec3f colour;
  };
  std::vector<Candidate> cand;
  for (int r = 0; r < depth.rows; ++r) {
    for (int c = 0; c < depth.cols; ++c) {
      const float d = depth.at<float>(r, c);
      if (!std::isfinite(d)) continue;
      const Eigen::Vector3d X = O + double(d) * (R * view.EyeRay(tile.x + c + 0.5, tile.y + r + 0.5));
      const Eigen::Vector3d to_eye = (O - X).normalized();
      cand.clear();
      for (size_t k = 0; k < cams.size(); ++k) {
        const double cosang = to_eye.dot((centres[k] - X).normalized());
        const auto uv = cams[k].Project(X);
        if (!uv || !cams[k].InImage(*uv)) continue;
        // Cameras facing the eye's side dominate; when none does (the Utrecht
        // rig has no camera behind the person) the least oblique one still wins.
        const double w = (cosang > 0 ? std::pow(cosang, options.angle_power) : 0.0) + 1e-9 * (1.0 + cosang);
        cand.push_back({w, Bilinear(images[k].image, uv->x(), uv->y())});
      }
      cv::Vec3b& px = out.at<cv::Vec3b>(r, c);
      if (cand.empty()) {
        px = cv::Vec3b(128, 128, 128);
        continue;
      }
      const size_t keep = std::min(cand.size(), size_t(options.max_cameras));
      std::partial_sort(cand.begin(), cand.begin() + long(keep), cand.end(),
                        [](const Candidate& a, const Candidate& b) { return a.weight > b.weight; });
      cv::Vec3f sum(0, 0, 0);
      double wsum = 0;
      for (size_t k = 0; k < keep; ++k) {
        sum += cand[k].colour * float(cand[k].weight);
        wsum += cand[k].weight;
      }
      sum *= float(1.0 / wsum);
      px = cv::Vec3b(cv::saturate_cast<uint8_t>(sum[0]), cv::saturate_cast<uint8_t>(sum[1]),
                     cv::saturate_cast<uint8_t>(sum[2]));
    }
  }
  return out;
}

}  // namespace hullpipe
