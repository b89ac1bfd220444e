#include "hullpipe/exact_hull.h"

#include <algorithm>
#include <cmath>

#include "hullpipe/conventions.h"
#include "hullpipe/plane_sweep.h"

namespace hullpipe {

Intervals IntersectIntervals(const Intervals& a, const Intervals& b) {
  Intervals out;
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const double lo = std::max(a[i].first, b[j].first), hi = std::min(a[i].second, b[j].second);
    if (lo <= hi) out.emplace_back(lo, hi);
    (a[i].second < b[j].second) ? ++i : ++j;
  }
  return out;
}

namespace {

// Is the camera-frame point on an object pixel of camera c (double precision)?
bool ObjectAt(const CameraMap& cm, const Eigen::Vector3d& X_world) {
  const auto uv = cm.camera.Project(X_world);
  if (!uv || !cm.camera.InImage(*uv)) return false;
  return cm.map.at<uint8_t>(int(uv->y()), int(uv->x())) != 0;
}

// Appends the parameters in (s0, s1) where a + b s = k (c + d s) for integer k,
// i.e. where the Möbius function f(s) = (a + b s) / (c + d s) crosses an integer,
// with c + d s > 0 on [s0, s1].
void MobiusCrossings(double a, double b, double c, double d, double s0, double s1, std::vector<double>* out) {
  const double f0 = (a + b * s0) / (c + d * s0), f1 = (a + b * s1) / (c + d * s1);
  const double lo = std::min(f0, f1), hi = std::max(f0, f1);
  // Bound the count: a ray grazing a camera can sweep a huge range of pixels.
  const double k_lo = std::max(std::ceil(lo), -1.0), k_hi = std::min(std::floor(hi), 1e5);
  for (double k = k_lo; k <= k_hi; k += 1.0) {
    const double den = b - k * d;
    if (den == 0) continue;
    const double s = (k * c - a) / den;
    if (s > s0 && s < s1) out->push_back(s);
  }
}

}  // namespace

Intervals RayCameraIntervals(const VolumeQuery& q, size_t ci, const Eigen::Vector3d& o, const Eigen::Vector3d& dir,
                             double s_min, double s_max) {
  const CameraMap& cm = q.views()[ci];
  const Camera& cam = cm.camera;
  Intervals out;
  if (!(s_max > s_min)) return out;
  const Eigen::Vector3d A = cam.cam_from_world * o, B = cam.cam_from_world.rotation * dir;
  // Restrict to z > 0 (in front of the camera).
  double s0 = s_min, s1 = s_max;
  const double eps_z = 1e-9;
  if (std::abs(B.z()) < 1e-300) {
    if (A.z() <= eps_z) return out;
  } else {
    const double sz = (eps_z - A.z()) / B.z();
    if (B.z() > 0) s0 = std::max(s0, sz);
    else s1 = std::min(s1, sz);
  }
  if (!(s1 > s0)) return out;
  std::vector<double> breaks = {s0, s1};
  bool distorted = false;
  for (double k : cam.distortion) distorted |= k != 0;
  if (!distorted) {
    // u = fx x/z + cx: (fx A.x + cx A.z + s (fx B.x + cx B.z)) / (A.z + s B.z).
    MobiusCrossings(cam.fx * A.x() + cam.cx * A.z(), cam.fx * B.x() + cam.cx * B.z(), A.z(), B.z(), s0, s1, &breaks);
    MobiusCrossings(cam.fy * A.y() + cam.cy * A.z(), cam.fy * B.y() + cam.cy * B.z(), A.z(), B.z(), s0, s1, &breaks);
  } else {
    // Step so the projection moves at most ~0.25 px, bisect every pixel change.
    auto pixel = [&](double s) -> std::pair<long, long> {
      const auto uv = cam.Project(o + s * dir);
      if (!uv) return {-1000000, -1000000};
      return {long(std::floor(uv->x())), long(std::floor(uv->y()))};
    };
    double s = s0;
    auto prev = pixel(s);
    while (s < s1) {
      // Local pixel speed from a finite difference.
      const double h = 1e-6 * std::max(1.0, std::abs(s));
      const auto p0 = cam.Project(o + s * dir), p1 = cam.Project(o + (s + h) * dir);
      double step = (s1 - s0) / 64;
      if (p0 && p1) {
        const double speed = (*p1 - *p0).norm() / h;
        if (speed > 0) step = std::min(step, 0.25 / speed);
      }
      step = std::max(step, 1e-9);
      const double next = std::min(s + step, s1);
      const auto cur = pixel(next);
      if (cur != prev) {
        double lo = s, hi = next;
        for (int it = 0; it < 60 && hi - lo > 1e-12; ++it) {
          const double mid = 0.5 * (lo + hi);
          (pixel(mid) == prev ? lo : hi) = mid;
        }
        breaks.push_back(hi);
      }
      prev = cur;
      s = next;
    }
  }
  std::sort(breaks.begin(), breaks.end());
  for (size_t k = 0; k + 1 < breaks.size(); ++k) {
    const double a = breaks[k], b = breaks[k + 1];
    if (!(b > a)) continue;
    if (!ObjectAt(cm, o + 0.5 * (a + b) * dir)) continue;
    if (!out.empty() && std::abs(out.back().second - a) <= 1e-12) {
      out.back().second = b;
    } else {
      out.emplace_back(a, b);
    }
  }
  return out;
}

Intervals RayHullIntervals(const VolumeQuery& q, const Eigen::Vector3d& o, const Eigen::Vector3d& dir, double s_min,
                           double s_max) {
  double s0 = s_min, s1 = s_max;
  if (!q.workspace().ClipRay(o, dir, &s0, &s1)) return {};
  Intervals hull = {{s0, s1}};
  for (size_t c = 0; c < q.size() && !hull.empty(); ++c)
    hull = IntersectIntervals(hull, RayCameraIntervals(q, c, o, dir, hull.front().first, hull.back().second));
  return hull;
}

cv::Mat ExactHullDepth(const VolumeQuery& q, const NovelView& view, const cv::Rect& tile) {
  cv::Mat out(tile.height, tile.width, CV_32FC1, cv::Scalar(kNoDepth));
  const Eigen::Vector3d O = view.world_from_eye.translation;
  for (int r = 0; r < tile.height; ++r)
    for (int c = 0; c < tile.width; ++c) {
      const Eigen::Vector3d D = view.world_from_eye.rotation * view.EyeRay(tile.x + c + 0.5, tile.y + r + 0.5);
      double s0 = 1e-6, s1 = 1e6;
      if (!q.hull_box().ClipRay(O, D, &s0, &s1)) continue;
      const Intervals iv = RayHullIntervals(q, O, D, s0, s1);
      if (!iv.empty()) out.at<float>(r, c) = float(iv.front().first);  // eye z: D has z = 1
    }
  return out;
}

}  // namespace hullpipe
