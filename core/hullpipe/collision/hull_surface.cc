#include "hullpipe/collision/hull_surface.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include <Eigen/Eigenvalues>

#include "hullpipe/reconstruction/exact_hull.h"
#include "hullpipe/geometry/conventions.h"

namespace hullpipe {

std::optional<Eigen::Vector3d> FirstHullPointAlong(const VolumeQuery& query, const Eigen::Vector3d& origin,
                                                   const Eigen::Vector3d& dir, double s_max) {
  if (!(dir.squaredNorm() > 0) || !(s_max >= 0)) return std::nullopt;
  const Intervals iv = RayHullIntervals(query, origin, dir, 0.0, s_max);
  if (iv.empty()) return std::nullopt;
  return Eigen::Vector3d(origin + iv.front().first * dir);
}

std::optional<double> FirstSampledCrossing(const VolumeQuery& query, const Eigen::Vector3d& origin,
                                           const Eigen::Vector3d& dir, double s_begin, double s_end, bool inside,
                                           double step, double tolerance) {
  const double len = dir.norm();
  if (!(len > 0) || !(s_end >= s_begin) || !(step > 0) || !(tolerance > 0)) return std::nullopt;
  auto is = [&](double s) { return query.Inside(origin + s * dir) == inside; };
  if (is(s_begin)) return s_begin;
  const int n = std::max(1, int(std::ceil((s_end - s_begin) * len / step)));
  double prev = s_begin;  // the last sample of the other kind
  for (int k = 1; k <= n; ++k) {
    const double sk = s_begin + (s_end - s_begin) * k / n;
    if (!is(sk)) {
      prev = sk;
      continue;
    }
    double lo = prev, hi = sk;
    while ((hi - lo) * len > tolerance) {
      const double mid = 0.5 * (lo + hi);
      (is(mid) ? hi : lo) = mid;
    }
    return hi;
  }
  return std::nullopt;
}

void HullNormalOptions::Check() const {
  if (!(border_px > 0)) throw std::invalid_argument("HullNormalOptions.border_px must be > 0");
  if (fit_radius_px < 1) throw std::invalid_argument("HullNormalOptions.fit_radius_px must be >= 1");
}

namespace {

// One object/background pixel edge of a map: its midpoint (pixel coordinates,
// hullpipe convention: pixel (x, y) covers [x, x+1) x [y, y+1)) and direction.
struct BorderEdge {
  Eigen::Vector2d mid;
  Eigen::Vector2d dir;
  Eigen::Vector2d out;  // unit, from the object pixel to the background one
};

// The border edges of `map` among pixels within `radius` of uv.
std::vector<BorderEdge> BorderEdgesNear(const cv::Mat& map, const Eigen::Vector2d& uv, int radius) {
  std::vector<BorderEdge> edges;
  const int cx = FloorPixel(uv.x()), cy = FloorPixel(uv.y());
  auto obj = [&](int x, int y) { return map.at<uint8_t>(y, x) != 0; };
  for (int y = cy - radius; y <= cy + radius; ++y)
    for (int x = cx - radius; x <= cx + radius; ++x) {
      if (x < 0 || y < 0 || x >= map.cols || y >= map.rows) continue;
      // Edge with the right neighbour (vertical segment at u = x + 1).
      if (x + 1 < map.cols && obj(x, y) != obj(x + 1, y))
        edges.push_back({{x + 1.0, y + 0.5}, {0, 1}, {obj(x, y) ? 1.0 : -1.0, 0}});
      // Edge with the neighbour below (horizontal segment at v = y + 1).
      if (y + 1 < map.rows && obj(x, y) != obj(x, y + 1))
        edges.push_back({{x + 0.5, y + 1.0}, {1, 0}, {0, obj(x, y) ? 1.0 : -1.0}});
    }
  return edges;
}

// Distance from point p to the unit-length segment centred at e.mid along e.dir.
double DistanceToEdge(const Eigen::Vector2d& p, const BorderEdge& e) {
  const Eigen::Vector2d d = p - e.mid;
  const double along = std::clamp(d.dot(e.dir), -0.5, 0.5);
  return (d - along * e.dir).norm();
}

// Outward normal of camera c's silhouette cone at X, from the border edges near
// X's projection uv; nullopt if there are none.
std::optional<Eigen::Vector3d> ConeNormal(const Camera& cam, const Eigen::Vector2d& uv,
                                          const std::vector<BorderEdge>& near, const Eigen::Vector3d& X) {
  if (near.empty()) return std::nullopt;
  // The contour's direction: principal axis of the edge midpoints, or the one
  // edge's direction. Its outward side: the mean of the edges' outward normals.
  Eigen::Vector2d mean = Eigen::Vector2d::Zero(), out = Eigen::Vector2d::Zero();
  for (const auto& e : near) mean += e.mid, out += e.out;
  mean /= double(near.size());
  Eigen::Vector2d t = near.front().dir;
  if (near.size() >= 3) {
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    for (const auto& e : near) cov += (e.mid - mean) * (e.mid - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(cov);
    t = es.eigenvectors().col(1);  // largest eigenvalue
  }
  if (!(out.squaredNorm() > 0)) out = Eigen::Vector2d(-t.y(), t.x());
  // The tangent plane holds the camera centre and the rays through uv and uv + t.
  const Eigen::Vector3d r0 = cam.PixelRayWorld(uv), r1 = cam.PixelRayWorld(uv + t);
  Eigen::Vector3d n = r0.cross(r1);
  if (!(n.squaredNorm() > 0)) return std::nullopt;
  n.normalize();
  // Outward: a small step along n moves X's projection toward the background.
  const double step = 1e-3 * std::max(1e-3, (X - cam.Center()).norm());
  const auto moved = cam.Project(X + step * n);
  if (moved && (*moved - uv).dot(out) < 0) n = -n;
  return n;
}

}  // namespace

std::optional<HullNormal> HullSurfaceNormal(const VolumeQuery& query, const Eigen::Vector3d& X,
                                            const HullNormalOptions& options) {
  options.Check();
  const int search = int(std::ceil(options.border_px)) + 1;
  HullNormal best;
  best.border_px = std::numeric_limits<double>::infinity();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int forming = 0;
  for (size_t i = 0; i < query.size(); ++i) {
    const CameraMap& cm = query.views()[i];
    const auto uv = cm.camera.Project(X);
    if (!uv || !cm.camera.InImage(*uv)) continue;
    // One scan of the window both tests need: the nearest border edge decides
    // whether this camera forms the surface, the edges within fit_radius_px fit it.
    const auto edges = BorderEdgesNear(cm.map, *uv, std::max(search, options.fit_radius_px));
    double d = std::numeric_limits<double>::infinity();
    for (const auto& e : edges) d = std::min(d, DistanceToEdge(*uv, e));
    if (!(d <= options.border_px)) continue;
    std::vector<BorderEdge> fit;
    for (const auto& e : edges)
      if ((e.mid - *uv).norm() <= options.fit_radius_px + 0.5) fit.push_back(e);
    const auto n = ConeNormal(cm.camera, *uv, fit, X);
    if (!n) continue;
    ++forming;
    best.cameras.push_back(int(i));
    sum += *n;
    if (d < best.border_px) {
      best.border_px = d;
      best.camera = int(i);
      best.normal = *n;
    }
  }
  if (forming == 0) return std::nullopt;
  if (forming > 1) {
    best.edge = true;
    if (sum.squaredNorm() > 0) best.normal = sum.normalized();
  }
  return best;
}

}  // namespace hullpipe
