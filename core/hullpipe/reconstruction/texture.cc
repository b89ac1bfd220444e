#include "hullpipe/reconstruction/texture.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/util/parallel.h"

namespace hullpipe {

void TextureOptions::Check() const {
  if (max_cameras < 1) throw std::invalid_argument("TextureOptions: max_cameras must be >= 1");
  if (!(angle_power >= 0)) throw std::invalid_argument("TextureOptions: angle_power must be >= 0");
  if (!(visibility_bias_m >= 0)) throw std::invalid_argument("TextureOptions: visibility_bias_m must be >= 0");
}

cv::Rect ImageRectAroundObjectPixels(const cv::Rect& r, cv::Size map_size, cv::Size image_size) {
  if (r.area() <= 0 || map_size.area() <= 0 || image_size.area() <= 0) return {};
  const double sx = double(image_size.width) / map_size.width, sy = double(image_size.height) / map_size.height;
  const int gx = 2 + int(std::ceil(sx)), gy = 2 + int(std::ceil(sy));
  const int x0 = int(std::floor(r.x * sx)) - gx, y0 = int(std::floor(r.y * sy)) - gy;
  const int x1 = int(std::ceil(r.br().x * sx)) + gx, y1 = int(std::ceil(r.br().y * sy)) + gy;
  return cv::Rect(cv::Point(x0, y0), cv::Point(x1, y1)) & cv::Rect(cv::Point(0, 0), image_size);
}

namespace {
// x^p for x > 0: by squaring where p is a whole number up to 64 (the default
// 8 costs three multiplies, std::pow about as much as the rest of a camera's
// weight), else std::pow.
double PowerOf(double x, double p) {
  if (!(p >= 0 && p <= 64 && p == std::floor(p))) return std::pow(x, p);
  double r = 1, b = x;
  for (unsigned e = unsigned(p); e; e >>= 1, b *= b)
    if (e & 1) r *= b;
  return r;
}

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

NovelView HullVisibilityView(const Camera& cam, int width) {
  const double s = double(width) / cam.width;
  NovelView v;
  v.width = width;
  v.height = std::max(1, int(std::lround(cam.height * s)));
  v.fx = cam.fx * s, v.fy = cam.fy * double(v.height) / cam.height;
  v.cx = cam.cx * s, v.cy = cam.cy * double(v.height) / cam.height;
  v.world_from_eye = cam.cam_from_world.Inverse();
  return v;
}

HullVisibility ComputeHullVisibility(const VolumeQuery& query, const std::vector<Camera>& cameras, int width,
                                     const PlaneSweepOptions& sweep, int refine_iterations, int threads,
                                     StopFlag stop) {
  HullVisibility vis;
  for (const Camera& cam : cameras) {
    const NovelView v = HullVisibilityView(cam, width);
    const auto depths = SweepPlaneDepths(query, v, sweep);
    vis.depth.push_back(PlaneSweepCpu(query, v, depths, {0, 0, v.width, v.height}, nullptr, threads, refine_iterations,
                                       stop));
    vis.views.push_back(v);
  }
  return vis;
}

namespace {
// Does camera k's hull depth map let it see world point X?
// eye_from_world: the inverse of vis.views[k].world_from_eye, computed once.
bool Visible(const HullVisibility& vis, size_t k, const Rigid3d& eye_from_world, const Eigen::Vector3d& X,
             double bias) {
  const NovelView& v = vis.views[k];
  const Eigen::Vector3d p = eye_from_world * X;
  if (!(p.z() > 0)) return false;
  const double u = v.fx * p.x() / p.z() + v.cx, w = v.fy * p.y() / p.z() + v.cy;
  if (!(u >= 0 && w >= 0 && u < v.width && w < v.height)) return false;
  // The hull's depth at the nearest pixel centre.
  const int x = std::clamp(int(u), 0, v.width - 1), y = std::clamp(int(w), 0, v.height - 1);
  const float d = vis.depth[k].at<float>(y, x);
  const double surface = std::isfinite(d) ? double(d) : std::numeric_limits<double>::infinity();
  const double footprint = p.z() / v.fx;
  return p.z() <= surface + bias + 2 * footprint;
}
}  // namespace

cv::Mat TextureHull(const cv::Mat& depth, const cv::Rect& tile, const NovelView& view,
                    const std::vector<CameraImage>& images, const TextureOptions& options,
                    const HullVisibility* visibility, StopFlag stop, int threads) {
  options.Check();
  CV_Assert(depth.type() == CV_32FC1 && depth.size() == tile.size());
  if (visibility && (visibility->views.size() != images.size() || visibility->depth.size() != images.size()))
    throw std::invalid_argument("TextureHull: visibility has " + std::to_string(visibility->views.size()) +
                                " cameras, images " + std::to_string(images.size()));
  cv::Mat out(tile.size(), CV_8UC3, cv::Scalar(0, 0, 0));
  std::vector<Camera> cams;
  std::vector<Eigen::Vector3d> centres;
  for (const auto& ci : images) {
    cams.push_back(ScaledCamera(ci.camera, ci.image.cols, ci.image.rows));
    centres.push_back(cams.back().Center());
  }
  std::vector<Rigid3d> eye_from_world;
  if (visibility)
    for (const auto& v : visibility->views) eye_from_world.push_back(v.world_from_eye.Inverse());
  const Eigen::Vector3d O = view.world_from_eye.translation;
  const Eigen::Matrix3d& R = view.world_from_eye.rotation;
  struct Candidate {
    double weight;
    size_t camera;
    Eigen::Vector2d uv;  // where the camera sees the point (sampled only if blended)
    bool seen;           // passes the visibility test (true without one)
  };
  // Rows in chunks (a hull covers few rows of a wide view: fixed bands would
  // leave a worker idle); the stop flag is polled per row and thrown from this
  // thread.
  constexpr int kRowChunk = 8;  // as the sweep's (a block row of its bounds)
  ForEachRowChunk(depth.rows, kRowChunk, threads, [&](int r0, int r1, int) {
    std::vector<Candidate> cand;
    for (int r = r0; r < r1 && !Stopped(stop); ++r) {
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
          const double w = (cosang > 0 ? PowerOf(cosang, options.angle_power) : 0.0) + 1e-9 * (1.0 + cosang);
          const bool seen = !visibility || Visible(*visibility, k, eye_from_world[k], X, options.visibility_bias_m);
          cand.push_back({w, k, *uv, seen});
        }
        // Only cameras that see the point, if any does; where none does (the back
        // of the person on the Utrecht rig) the best imaging camera still colours
        // it, as without the test: a guess rather than a grey hole.
        if (std::any_of(cand.begin(), cand.end(), [](const Candidate& x) { return x.seen; }))
          cand.erase(std::remove_if(cand.begin(), cand.end(), [](const Candidate& x) { return !x.seen; }), cand.end());
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
          const Candidate& b = cand[k];
          sum += Bilinear(images[b.camera].image, b.uv.x(), b.uv.y()) * float(b.weight);
          wsum += b.weight;
        }
        sum *= float(1.0 / wsum);
        px = cv::Vec3b(cv::saturate_cast<uint8_t>(sum[0]), cv::saturate_cast<uint8_t>(sum[1]),
                       cv::saturate_cast<uint8_t>(sum[2]));
      }
    }
  });
  ThrowIfStopped(stop, "texturing");
  return out;
}

}  // namespace hullpipe
