#include "hullpipe/collision/contact_region.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_map>

#include "hullpipe/reconstruction/exact_hull.h"

namespace hullpipe {

std::vector<ContactSegment> ExactContactSegments(const VolumeQuery& query, const TriangleViewport& vp, double spacing,
                                                 const ViewportWindow* window) {
  if (!(spacing > 0)) throw std::invalid_argument("ExactContactSegments: spacing must be > 0");
  std::vector<ContactSegment> out;
  const Eigen::Vector2d* p2[3] = {&vp.a2, &vp.b2, &vp.c2};
  auto world = [&](double x, double y) { return Eigen::Vector3d(vp.origin + x * vp.u_step + y * vp.v_step); };
  auto cut = [&](const Eigen::Vector3d& P, const Eigen::Vector3d& Q) {
    const Eigen::Vector3d d = Q - P;
    if (d.squaredNorm() == 0) {
      if (query.Inside(P)) out.push_back({P, P});
      return;
    }
    for (const auto& [s0, s1] : RayHullIntervals(query, P, d, 0.0, 1.0)) out.push_back({P + s0 * d, P + s1 * d});
  };
  const double area = (vp.b2 - vp.a2).x() * (vp.c2 - vp.a2).y() - (vp.b2 - vp.a2).y() * (vp.c2 - vp.a2).x();
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (const auto* p : p2) {
    xmin = std::min(xmin, p->x()), xmax = std::max(xmax, p->x());
    ymin = std::min(ymin, p->y()), ymax = std::max(ymax, p->y());
  }
  if (area == 0) {  // a segment (or a point): one line along it
    double x0 = xmin, x1 = xmax;
    if (window) x0 = std::max(x0, window->x0), x1 = std::min(x1, window->x1);
    if (x0 <= x1) cut(world(x0, 0.5 * (ymin + ymax)), world(x1, 0.5 * (ymin + ymax)));
    return out;
  }
  // The three edges, clipped to the window: they carry the region's thin parts
  // (a sliver's ends, sharp corners) that no line across reaches.
  for (int e = 0; e < 3; ++e) {
    const Eigen::Vector2d s0 = *p2[e], d = *p2[(e + 1) % 3] - s0;
    double t0 = 0, t1 = 1;
    if (window) {
      const double lo[2] = {window->x0, window->y0}, hi[2] = {window->x1, window->y1};
      for (int k = 0; k < 2 && t0 <= t1; ++k) {
        if (d[k] == 0) {
          if (s0[k] < lo[k] || s0[k] > hi[k]) t1 = -1;
          continue;
        }
        double a = (lo[k] - s0[k]) / d[k], b = (hi[k] - s0[k]) / d[k];
        if (a > b) std::swap(a, b);
        t0 = std::max(t0, a), t1 = std::min(t1, b);
      }
    }
    if (t0 <= t1) cut(world(s0.x() + t0 * d.x(), s0.y() + t0 * d.y()), world(s0.x() + t1 * d.x(), s0.y() + t1 * d.y()));
  }
  double y0 = ymin, y1 = ymax;
  if (window) y0 = std::max(y0, window->y0), y1 = std::min(y1, window->y1);
  if (!(y1 >= y0)) return out;
  const double pixel_v = vp.v_step.norm();
  const int lines = std::max(1, int(std::ceil((y1 - y0) * pixel_v / spacing)));
  for (int k = 0; k < lines; ++k) {
    const double y = y0 + (k + 0.5) * (y1 - y0) / lines;
    // The triangle's chord at this y: where the line crosses its edges.
    double lo = 1e300, hi = -1e300;
    for (int e = 0; e < 3; ++e) {
      const Eigen::Vector2d& s = *p2[e];
      const Eigen::Vector2d& t = *p2[(e + 1) % 3];
      if ((s.y() - y) * (t.y() - y) > 0) continue;
      if (s.y() == t.y()) {
        lo = std::min({lo, s.x(), t.x()}), hi = std::max({hi, s.x(), t.x()});
        continue;
      }
      const double x = s.x() + (y - s.y()) / (t.y() - s.y()) * (t.x() - s.x());
      lo = std::min(lo, x), hi = std::max(hi, x);
    }
    if (window) lo = std::max(lo, window->x0), hi = std::min(hi, window->x1);
    if (lo <= hi) cut(world(lo, y), world(hi, y));
  }
  return out;
}

namespace {

double PointSegmentDistance(const Eigen::Vector3d& x, const ContactSegment& s) {
  const Eigen::Vector3d d = s.q - s.p;
  const double len2 = d.squaredNorm();
  const double t = len2 > 0 ? std::clamp((x - s.p).dot(d) / len2, 0.0, 1.0) : 0.0;
  return (s.p + t * d - x).norm();
}

// Nearest-point queries over a fixed set of points, by a uniform hash grid
// searched in growing shells of cells.
class PointGrid {
 public:
  explicit PointGrid(const std::vector<Eigen::Vector3d>& pts) : pts_(pts) {
    Eigen::Vector3d lo = pts[0], hi = pts[0];
    for (const auto& p : pts) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    Eigen::Vector3d ext = hi - lo;
    std::sort(ext.data(), ext.data() + 3);
    // Points of one triangle lie on a plane: a cell holds about one point.
    cell_ = std::max(1e-7, std::sqrt(std::max(ext[2] * std::max(ext[1], 1e-9), 1e-14) / double(pts.size())));
    origin_ = lo;
    for (size_t i = 0; i < pts.size(); ++i) {
      const Eigen::Vector3i c = Cell(pts[i]);
      cmin_ = i == 0 ? c : cmin_.cwiseMin(c);
      cmax_ = i == 0 ? c : cmax_.cwiseMax(c);
      cells_[Key(c)].push_back(int(i));
    }
  }
  double Nearest(const Eigen::Vector3d& x) const {
    const Eigen::Vector3i c = Cell(x);
    // Shells beyond this radius hold no cell of the grid.
    const int rmax = (c - cmin_).cwiseAbs().maxCoeff() + (cmax_ - cmin_).maxCoeff() + 1;
    double best = std::numeric_limits<double>::infinity();
    for (int r = 0; r <= rmax; ++r) {
      if (best <= (r - 1) * cell_) break;  // every point of shell r is >= (r-1) cells away
      if (r > 6) {  // far from every point: scanning them all is cheaper than the shells
        for (const auto& p : pts_) best = std::min(best, (p - x).norm());
        break;
      }
      for (int dz = -r; dz <= r; ++dz)
        for (int dy = -r; dy <= r; ++dy)
          for (int dx = -r; dx <= r; ++dx) {
            if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) != r) {
              dx = r - 1;  // skip the inside of the shell's row
              continue;
            }
            const auto it = cells_.find(Key(c + Eigen::Vector3i(dx, dy, dz)));
            if (it == cells_.end()) continue;
            for (int i : it->second) best = std::min(best, (pts_[size_t(i)] - x).norm());
          }
    }
    return best;
  }

 private:
  Eigen::Vector3i Cell(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d f = ((p - origin_) / cell_).array().floor();
    return f.cwiseMax(-1e6).cwiseMin(1e6).cast<int>();
  }
  static int64_t Key(const Eigen::Vector3i& c) {
    return (int64_t(c.x() + (1 << 20)) << 42) | (int64_t(c.y() + (1 << 20)) << 21) | int64_t(c.z() + (1 << 20));
  }
  const std::vector<Eigen::Vector3d>& pts_;
  double cell_ = 1;
  Eigen::Vector3d origin_;
  Eigen::Vector3i cmin_, cmax_;
  std::unordered_map<int64_t, std::vector<int>> cells_;
};

}  // namespace

ContactError CollisionPointError(const std::vector<Eigen::Vector3d>& points,
                                 const std::vector<ContactSegment>& region, double sample) {
  if (!(sample > 0)) throw std::invalid_argument("CollisionPointError: sample must be > 0");
  ContactError e;
  const double inf = std::numeric_limits<double>::infinity();
  if (points.empty() && region.empty()) return e;
  if (region.empty()) {
    e.points_to_region = inf;
    return e;
  }
  if (points.empty()) {
    e.region_to_points = inf;
    return e;
  }
  for (const auto& x : points) {
    double best = inf;
    for (const auto& s : region) best = std::min(best, PointSegmentDistance(x, s));
    e.points_to_region = std::max(e.points_to_region, best);
  }
  e.region_to_points = UncoveredDistances(points, {region}, sample)[0];
  return e;
}

std::vector<double> UncoveredDistances(const std::vector<Eigen::Vector3d>& points,
                                       const std::vector<std::vector<ContactSegment>>& regions, double sample) {
  if (!(sample > 0)) throw std::invalid_argument("UncoveredDistances: sample must be > 0");
  std::vector<double> out(regions.size(), 0.0);
  if (points.empty()) {
    for (size_t r = 0; r < regions.size(); ++r)
      if (!regions[r].empty()) out[r] = std::numeric_limits<double>::infinity();
    return out;
  }
  const PointGrid grid(points);
  for (size_t r = 0; r < regions.size(); ++r)
    for (const auto& s : regions[r]) {
      const double len = (s.q - s.p).norm();
      const int n = std::max(1, int(std::ceil(len / sample)));
      for (int k = 0; k <= n; ++k) out[r] = std::max(out[r], grid.Nearest(s.p + (s.q - s.p) * (double(k) / n)));
    }
  return out;
}

}  // namespace hullpipe
