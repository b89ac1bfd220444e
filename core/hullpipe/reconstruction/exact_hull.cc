#include "hullpipe/reconstruction/exact_hull.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/util/parallel.h"
#include "hullpipe/reconstruction/plane_sweep.h"

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

// Appends the parameters in (s0, s1) where a + b s = k (c + d s) for integer k,
// i.e. where the Möbius function f(s) = (a + b s) / (c + d s) crosses an integer,
// with c + d s > 0 on [s0, s1]. Only k in [0, side]: the image's pixel lines;
// beyond them every point is out of view, one vote, so crossings there split
// nothing (a ray grazing a camera sweeps millions of pixel widths there, and
// sorting them once took 70% of an exact run).
void MobiusCrossings(double a, double b, double c, double d, double s0, double s1, int side,
                     std::vector<double>* out) {
  const double f0 = (a + b * s0) / (c + d * s0), f1 = (a + b * s1) / (c + d * s1);
  const double lo = std::min(f0, f1), hi = std::max(f0, f1);
  const double k_lo = std::max(std::ceil(lo), 0.0), k_hi = std::min(std::floor(hi), double(side));
  for (double k = k_lo; k <= k_hi; k += 1.0) {
    const double den = b - k * d;
    if (den == 0) continue;
    const double s = (k * c - a) / den;
    if (s > s0 && s < s1) out->push_back(s);
  }
}

}  // namespace

std::vector<VoteSegment> RayCameraSegments(const VolumeQuery& q, size_t ci, const Eigen::Vector3d& o,
                                           const Eigen::Vector3d& dir, double s_min, double s_max) {
  const CameraMap& cm = q.views().at(ci);
  const Camera& cam = cm.camera;
  std::vector<VoteSegment> out;
  if (!(s_max > s_min)) return out;
  const Eigen::Vector3d A = cam.cam_from_world * o, B = cam.cam_from_world.rotation * dir;
  // The part in front of the camera (z > 0); the rest is unseen.
  double s0 = s_min, s1 = s_max;
  const double eps_z = 1e-9;
  if (std::abs(B.z()) < 1e-300) {
    if (A.z() <= eps_z) s1 = s0;
  } else {
    const double sz = (eps_z - A.z()) / B.z();
    if (B.z() > 0) s0 = std::max(s0, sz);
    else s1 = std::min(s1, sz);
  }
  std::vector<double> breaks = {s_min, s_max};
  if (s1 > s0) {
    breaks.push_back(s0);
    breaks.push_back(s1);
    bool distorted = false;
    for (double k : cam.distortion) distorted |= k != 0;
    if (!distorted) {
      // u = (fx x + skew y)/z + cx:
      // (fx A.x + skew A.y + cx A.z + s (fx B.x + skew B.y + cx B.z)) / (A.z + s B.z).
      MobiusCrossings(cam.fx * A.x() + cam.skew * A.y() + cam.cx * A.z(),
                      cam.fx * B.x() + cam.skew * B.y() + cam.cx * B.z(), A.z(), B.z(), s0, s1, cam.width,
                      &breaks);
      MobiusCrossings(cam.fy * A.y() + cam.cy * A.z(), cam.fy * B.y() + cam.cy * B.z(), A.z(), B.z(), s0, s1,
                      cam.height, &breaks);
    } else {
      // Step so the projection moves at most ~0.5 px, bisect every change of
      // pixel (or of seen/unseen, at the valid radius).
      auto pixel = [&](double s) -> std::pair<long, long> {
        const auto uv = cam.Project(o + s * dir);
        if (!uv) return {-1000000, -1000000};
        return {long(std::floor(uv->x())), long(std::floor(uv->y()))};
      };
      double s = s0;
      auto prev = pixel(s);
      while (s < s1) {
        const double h = 1e-6 * std::max(1.0, std::abs(s));
        const auto p0 = cam.Project(o + s * dir), p1 = cam.Project(o + (s + h) * dir);
        double step = (s1 - s0) / 64;
        if (p0 && p1) {
          const double speed = (*p1 - *p0).norm() / h;
          if (speed > 0) step = std::min(step, 0.5 / speed);
        }
        step = std::max(step, 1e-9);
        const double next = std::min(s + step, s1);
        const auto cur = pixel(next);
        // Column and row crossings are bisected separately, so a step that
        // crosses both (a pixel corner) yields both breaks.
        for (const bool column : {true, false}) {
          auto index = [&](const std::pair<long, long>& px) { return column ? px.first : px.second; };
          if (index(cur) == index(prev)) continue;
          double lo = s, hi = next;
          for (int it = 0; it < 60 && hi - lo > 1e-12; ++it) {
            const double mid = 0.5 * (lo + hi);
            (index(pixel(mid)) == index(prev) ? lo : hi) = mid;
          }
          breaks.push_back(hi);
        }
        prev = cur;
        s = next;
      }
    }
  }
  std::sort(breaks.begin(), breaks.end());
  for (size_t k = 0; k + 1 < breaks.size(); ++k) {
    const double a = breaks[k], b = breaks[k + 1];
    if (!(b > a)) continue;
    const Vote v = q.VoteOf(ci, o + 0.5 * (a + b) * dir);
    if (!out.empty() && out.back().vote == v) {
      out.back().s1 = b;
    } else {
      out.push_back({a, b, v});
    }
  }
  return out;
}

Intervals RayCameraIntervals(const VolumeQuery& q, size_t ci, const Eigen::Vector3d& o, const Eigen::Vector3d& dir,
                             double s_min, double s_max) {
  Intervals out;
  for (const auto& seg : RayCameraSegments(q, ci, o, dir, s_min, s_max))
    if (seg.vote == Vote::kObject) out.emplace_back(seg.s0, seg.s1);
  return out;
}

Intervals RayHullIntervals(const VolumeQuery& q, const Eigen::Vector3d& o, const Eigen::Vector3d& dir, double s_min,
                           double s_max) {
  double s0 = s_min, s1 = s_max;
  if (!q.workspace().ClipRay(o, dir, &s0, &s1) || !(s1 > s0)) return {};
  const size_t n = q.size();
  std::vector<std::vector<VoteSegment>> segs(n);
  std::vector<double> breaks;
  for (size_t c = 0; c < n; ++c) {
    segs[c] = RayCameraSegments(q, c, o, dir, s0, s1);
    for (const auto& sg : segs[c]) breaks.push_back(sg.s0);
  }
  breaks.push_back(s1);
  std::sort(breaks.begin(), breaks.end());
  breaks.erase(std::unique(breaks.begin(), breaks.end()), breaks.end());
  // Walk the elementary pieces; each camera's vote is constant on each.
  std::vector<size_t> at(n, 0);
  Intervals out;
  for (size_t k = 0; k + 1 < breaks.size(); ++k) {
    const double a = breaks[k], b = breaks[k + 1], mid = 0.5 * (a + b);
    int object = 0, unseen = 0;
    bool background = false;
    for (size_t c = 0; c < n; ++c) {
      while (at[c] + 1 < segs[c].size() && segs[c][at[c]].s1 <= mid) ++at[c];
      switch (segs[c][at[c]].vote) {
        case Vote::kBackground: background = true; break;
        case Vote::kObject: ++object; break;
        case Vote::kUnseen: ++unseen; break;
      }
    }
    if (background || !q.Accepts(object, unseen)) continue;
    if (!out.empty() && out.back().second == a) {
      out.back().second = b;
    } else {
      out.emplace_back(a, b);
    }
  }
  return out;
}

cv::Mat ExactHullDepth(const VolumeQuery& q, const NovelView& view, const cv::Rect& tile, int threads) {
  cv::Mat out(tile.height, tile.width, CV_32FC1, cv::Scalar(kNoDepth));
  const Eigen::Vector3d O = view.world_from_eye.translation;
  ForEachRowBand(tile.height, threads, [&](int r0, int r1, int) {
    for (int r = r0; r < r1; ++r)
      for (int c = 0; c < tile.width; ++c) {
        const Eigen::Vector3d D = view.world_from_eye.rotation * view.EyeRay(tile.x + c + 0.5, tile.y + r + 0.5);
        double s0 = 1e-6, s1 = 1e6;
        if (!q.hull_box().ClipRay(O, D, &s0, &s1)) continue;
        const Intervals iv = RayHullIntervals(q, O, D, s0, s1);
        if (!iv.empty()) out.at<float>(r, c) = float(iv.front().first);  // eye z: D has z = 1
      }
  });
  return out;
}

HullSamples SampleHull(const VolumeQuery& q, const Aabb& region_in, double step) {
  HullSamples out;
  out.step = step;
  const Aabb region = region_in.Intersection(q.hull_box());
  if (region.empty() || !(step > 0) || q.ProvesEmpty(region)) return out;
  const Eigen::Vector3d size = region.max - region.min;
  const int nx = int(std::floor(size.x() / step)) + 1, ny = int(std::floor(size.y() / step)) + 1,
            nz = int(std::floor(size.z() / step)) + 1;
  constexpr int kBlock = 4;
  size_t hint = 0;
  for (int bz = 0; bz < nz; bz += kBlock)
    for (int by = 0; by < ny; by += kBlock)
      for (int bx = 0; bx < nx; bx += kBlock) {
        Aabb block;
        block.min = region.min + Eigen::Vector3d(bx, by, bz) * step;
        block.max = region.min + Eigen::Vector3d(std::min(bx + kBlock - 1, nx - 1), std::min(by + kBlock - 1, ny - 1),
                                                 std::min(bz + kBlock - 1, nz - 1)) * step;
        if (q.ProvesEmpty(block, &hint)) continue;
        for (int k = bz; k < std::min(bz + kBlock, nz); ++k)
          for (int j = by; j < std::min(by + kBlock, ny); ++j)
            for (int i = bx; i < std::min(bx + kBlock, nx); ++i) {
              const Eigen::Vector3d p = region.min + Eigen::Vector3d(i, j, k) * step;
              if (q.Inside(p)) out.points.push_back(p);
            }
      }
  return out;
}

namespace {
// The step of a grid over `box` with at most 200,000 points, at least `step`:
// a hull box as large as a room costs what a person's does.
double CappedStep(const Aabb& box, double step) {
  constexpr double kMaxPoints = 2e5;
  const Eigen::Vector3d size = (box.max - box.min).cwiseMax(step);
  if (size.prod() / (step * step * step) > kMaxPoints) step = std::cbrt(size.prod() / kMaxPoints);
  return step;
}
}  // namespace

Aabb SampledHullBox(const VolumeQuery& q, double step) {
  if (!(step > 0)) throw std::invalid_argument("SampledHullBox: step must be > 0");
  const Aabb& box = q.hull_box();
  if (box.empty()) return box;
  step = CappedStep(box, step);
  const HullSamples s = SampleHull(q, box, step);
  if (s.points.empty()) return box;
  Aabb out;
  out.min = out.max = s.points.front();
  for (const Eigen::Vector3d& p : s.points) out.min = out.min.cwiseMin(p), out.max = out.max.cwiseMax(p);
  out.min.array() -= step;
  out.max.array() += step;
  return out.Intersection(box);
}

std::optional<double> HullExtentAlong(const VolumeQuery& q, const Eigen::Vector3d& dir_in, double step) {
  if (!(step > 0)) throw std::invalid_argument("HullExtentAlong: step must be > 0");
  if (!(dir_in.norm() > 0) || !dir_in.allFinite()) throw std::invalid_argument("HullExtentAlong: dir must be non-zero");
  const Aabb& box = q.hull_box();
  if (box.empty()) return std::nullopt;
  const Eigen::Vector3d dir = dir_in.normalized();
  step = CappedStep(box, step);
  std::vector<std::pair<double, Eigen::Vector3d>> inside;
  for (const Eigen::Vector3d& p : SampleHull(q, box, step).points) inside.emplace_back(dir.dot(p), p);
  if (inside.empty()) {
    // A hull thinner than the grid: the box's farthest corner, which holds it.
    double corner = -1e300;
    for (const auto& c : box.Corners()) corner = std::max(corner, dir.dot(c));
    return corner;
  }
  const size_t k = std::min<size_t>(32, inside.size());
  std::partial_sort(inside.begin(), inside.begin() + long(k), inside.end(),
                    [](const auto& a, const auto& b) { return a.first > b.first; });
  // The hull's reach along the line through p in direction dir: from where the
  // line leaves the hull box back towards p in steps of step / 8, the first
  // inside point, then bisection to 1e-7 m against the outside point a step
  // beyond. Point queries, not the exact ray-hull intervals: these walk every
  // camera along the whole line, and 128 lines over 20 distorted cameras took
  // render 1.9 s at its first hull. A part beyond that point thinner than a
  // step along dir can be missed (the reach stays a hull point's).
  const double march = step / 8;
  auto line_reach = [&](const Eigen::Vector3d& p) {
    double a = -1e300, b = 1e300;
    if (!box.ClipRay(p, dir, &a, &b)) return -1e300;
    for (double s = b; s >= a; s -= march) {
      if (!q.Inside(p + s * dir)) continue;
      double in = s, out = s + march;
      if (s == b) return dir.dot(p) + b;  // inside at the box's face itself
      while (out - in > 1e-7) {
        const double mid = 0.5 * (in + out);
        (q.Inside(p + mid * dir) ? in : out) = mid;
      }
      return dir.dot(p) + in;
    }
    return -1e300;
  };
  double best = inside[0].first;
  Eigen::Vector3d best_line = inside[0].second;
  for (size_t i = 0; i < k; ++i) {
    const double r = line_reach(inside[i].second);
    if (r > best) best = r, best_line = inside[i].second;
  }
  // The extreme point may be a corner of the hull (where silhouette cones
  // meet) between the lines: lines around the best one, 5 x 5 at half the
  // spacing each time, down to step / 64.
  const Eigen::Vector3d a = dir.unitOrthogonal(), b = dir.cross(a);
  for (double h = step / 2; h >= step / 64; h /= 2) {
    const Eigen::Vector3d centre = best_line;
    for (int i = -2; i <= 2; ++i)
      for (int j = -2; j <= 2; ++j) {
        if (i == 0 && j == 0) continue;
        const Eigen::Vector3d p = centre + (i * h) * a + (j * h) * b;
        const double r = line_reach(p);
        if (r > best) best = r, best_line = p;
      }
  }
  return best;
}

}  // namespace hullpipe
