#include "hullpipe/collision/triangle_query.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "hullpipe/util/parallel.h"
#include <string>

#include "hullpipe/geometry/conventions.h"

namespace hullpipe {

void TriangleQueryOptions::Check() const {
  const std::string side = std::to_string(kMaxViewportSide);
  if (fixed_viewport < 0 || fixed_viewport > kMaxViewportSide)
    throw std::invalid_argument("collision: fixed_viewport must be in [0, " + side + "] pixels (0: sized by "
                                "max_pixel_size)");
  if (fixed_viewport == 0 && !(max_pixel_size >= kMinPixelSize && max_pixel_size <= 1))
    throw std::invalid_argument("collision: max_pixel_size must be in [1e-05, 1] m");
  if (max_viewport < 1 || max_viewport > kMaxViewportSide)
    throw std::invalid_argument("collision: max_viewport must be in [1, " + side + "] pixels");
}

TriangleViewport MakeTriangleViewport(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                      const Eigen::Vector3d& c, const TriangleQueryOptions& o) {
  TriangleViewport vp;
  // Orthonormal in-plane axes: u along the longest edge from its start, v across.
  Eigen::Vector3d p0 = a, p1 = b;
  if ((c - b).norm() > (p1 - p0).norm()) p0 = b, p1 = c;
  if ((a - c).norm() > (p1 - p0).norm()) p0 = c, p1 = a;
  Eigen::Vector3d u = p1 - p0;
  const double len = u.norm();
  u = len > 0 ? Eigen::Vector3d(u / len) : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d n = (b - a).cross(c - a);
  Eigen::Vector3d v = n.norm() > 1e-18 ? Eigen::Vector3d(n.cross(u).normalized()) : u.unitOrthogonal();
  double umin = 1e300, umax = -1e300, vmin = 1e300, vmax = -1e300;
  for (const auto* p : {&a, &b, &c}) {
    const double pu = (*p - p0).dot(u), pv = (*p - p0).dot(v);
    umin = std::min(umin, pu), umax = std::max(umax, pu);
    vmin = std::min(vmin, pv), vmax = std::max(vmax, pv);
  }
  const double eu = umax - umin, ev = vmax - vmin;
  int w, h;
  if (o.fixed_viewport > 0) {
    w = h = o.fixed_viewport;
  } else {
    w = std::clamp(CeilPixel(eu / o.max_pixel_size), 1, o.max_viewport);
    h = std::clamp(CeilPixel(ev / o.max_pixel_size), 1, o.max_viewport);
  }
  const double su = eu > 0 ? eu / w : 1e-9, sv = ev > 0 ? ev / h : 1e-9;
  vp.width = w;
  vp.height = h;
  vp.origin = p0 + umin * u + vmin * v;
  vp.u_step = su * u;
  vp.v_step = sv * v;
  auto to2 = [&](const Eigen::Vector3d& p) {
    return Eigen::Vector2d(((p - p0).dot(u) - umin) / su, ((p - p0).dot(v) - vmin) / sv);
  };
  vp.a2 = to2(a), vp.b2 = to2(b), vp.c2 = to2(c);
  return vp;
}

namespace {

// The three edge functions of a viewport's triangle, oriented so that inside is
// >= 0 on all three (the same arithmetic as PixelInTriangle's definition).
struct EdgeTest {
  Eigen::Vector2d s[3], e[3];
  double sgn = 0;  // 0: degenerate, nothing inside
  explicit EdgeTest(const TriangleViewport& vp) {
    s[0] = vp.a2, e[0] = vp.b2, s[1] = vp.b2, e[1] = vp.c2, s[2] = vp.c2, e[2] = vp.a2;
    const double area = Edge(0, vp.c2);
    sgn = area > 0 ? 1.0 : area < 0 ? -1.0 : 0.0;
  }
  double Edge(int k, const Eigen::Vector2d& q) const {
    return (e[k].x() - s[k].x()) * (q.y() - s[k].y()) - (e[k].y() - s[k].y()) * (q.x() - s[k].x());
  }
  bool Inside(int i, int j) const {
    if (sgn == 0) return false;
    const Eigen::Vector2d p(i + 0.5, j + 0.5);
    return sgn * Edge(0, p) >= 0 && sgn * Edge(1, p) >= 0 && sgn * Edge(2, p) >= 0;
  }
};

// One camera's projection of the viewport's pixel centres: the camera-frame point
// of pixel (i, j) is p0 + (i + 0.5) du + (j + 0.5) dv (affine in the pixel, the
// view being orthographic), so each pixel costs a division and a lookup.
struct PixelCamera {
  Eigen::Vector3d p0, du, dv;
  const Camera* camera;
  double r2max;
  bool distorted;
  const cv::Mat* map;
};

// Camera c's vote on camera-frame point xc: the arithmetic of Camera::Project and
// VolumeQuery::VoteOf, in double precision.
Vote VoteAt(const PixelCamera& pc, const Eigen::Vector3d& xc) {
  if (!(xc.z() > 1e-9)) return Vote::kUnseen;
  Eigen::Vector2d xn(xc.x() / xc.z(), xc.y() / xc.z());
  if (xn.squaredNorm() > pc.r2max) return Vote::kUnseen;
  const Camera& c = *pc.camera;
  if (pc.distorted) xn = c.Distort(xn);
  const double u = c.fx * xn.x() + c.skew * xn.y() + c.cx, v = c.fy * xn.y() + c.cy;
  if (!(u >= 0 && v >= 0 && u < c.width && v < c.height)) return Vote::kUnseen;
  return pc.map->at<uint8_t>(int(v), int(u)) != 0 ? Vote::kObject : Vote::kBackground;
}

}  // namespace

bool TriangleChord(const TriangleViewport& vp, int axis, double at, double* lo, double* hi) {
  const Eigen::Vector2d* p[3] = {&vp.a2, &vp.b2, &vp.c2};
  const int other = 1 - axis;
  *lo = 1e300, *hi = -1e300;
  for (int e = 0; e < 3; ++e) {
    const Eigen::Vector2d& s = *p[e];
    const Eigen::Vector2d& t = *p[(e + 1) % 3];
    if ((s[axis] - at) * (t[axis] - at) > 0) continue;
    if (s[axis] == t[axis]) {
      *lo = std::min({*lo, s[other], t[other]}), *hi = std::max({*hi, s[other], t[other]});
      continue;
    }
    const double x = s[other] + (at - s[axis]) / (t[axis] - s[axis]) * (t[other] - s[other]);
    *lo = std::min(*lo, x), *hi = std::max(*hi, x);
  }
  return *lo <= *hi;
}

bool PixelInTriangle(const TriangleViewport& vp, int i, int j) { return EdgeTest(vp).Inside(i, j); }

TriangleQueryResult QueryTriangleCpu(const VolumeQuery& query, const Eigen::Vector3d& a,
                                     const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                     const TriangleQueryOptions& o) {
  const TriangleViewport vp = MakeTriangleViewport(a, b, c, o);
  const EdgeTest edges(vp);
  TriangleQueryResult result;
  const size_t n = query.size();
  std::vector<PixelCamera> cams(n);
  for (size_t k = 0; k < n; ++k) {
    const CameraMap& v = query.views()[k];
    const Rigid3d& T = v.camera.cam_from_world;
    cams[k] = {T * vp.origin, T.rotation * vp.u_step, T.rotation * vp.v_step, &v.camera,
               v.camera.MaxValidRadius2(), false, &v.map};
    for (double d : v.camera.distortion) cams[k].distorted |= d != 0.0;
  }
  // The workspace test is needed only if the triangle leaves the workspace.
  Aabb box;
  box.Extend(a), box.Extend(b), box.Extend(c);
  const Aabb& ws = query.workspace();
  const bool check_workspace = !(ws.Contains(box.min) && ws.Contains(box.max));
  size_t first = 0;  // the camera that vetoed last: neighbouring pixels tend to agree
  const bool thin = vp.height == 1;
  for (int j = 0; j < vp.height; ++j) {
    for (int i = 0; i < vp.width; ++i) {
      double fi = i + 0.5, fj = j + 0.5;
      if (thin) {
        // Thinner than a pixel: each column's sample is the middle of the
        // triangle's chord there, so a sliver is sampled along all its length.
        double lo, hi;
        if (!TriangleChord(vp, 0, fi, &lo, &hi)) continue;
        fj = 0.5 * (lo + hi);
      } else if (!edges.Inside(i, j)) {
        continue;
      }
      ++result.pixels_tested;
      if (check_workspace && !ws.Contains(vp.origin + fi * vp.u_step + fj * vp.v_step)) continue;
      int object = 0, unseen = 0;
      bool vetoed = false;
      for (size_t m = 0; m < n; ++m) {
        const size_t k = (first + m) % n;
        const PixelCamera& pc = cams[k];
        const Vote vote = VoteAt(pc, pc.p0 + fi * pc.du + fj * pc.dv);
        if (query.Vetoes(vote)) {
          vetoed = true;
          first = k;
          break;
        }
        object += vote == Vote::kObject;
        unseen += vote == Vote::kUnseen;
      }
      if (!vetoed && query.Accepts(object, unseen))
        result.collision_points.push_back(vp.origin + fi * vp.u_step + fj * vp.v_step);
    }
  }
  if (result.pixels_tested == 0) {
    result.pixels_tested = 1;
    const Eigen::Vector3d centroid = (a + b + c) / 3.0;
    if (query.Inside(centroid)) result.collision_points.push_back(centroid);
  }
  return result;
}

std::vector<TriangleQueryResult> QueryTrianglesCpu(const VolumeQuery& query, const std::vector<Triangle>& triangles,
                                                   const TriangleQueryOptions& options, int threads) {
  options.Check();
  std::vector<TriangleQueryResult> out(triangles.size());
  ForEachRowBand(int(triangles.size()), threads, [&](int t0, int t1, int) {
    for (int t = t0; t < t1; ++t) {
      const Triangle& tri = triangles[size_t(t)];
      out[size_t(t)] = QueryTriangleCpu(query, tri.a, tri.b, tri.c, options);
    }
  });
  return out;
}

std::vector<char> QueryPoints(const VolumeQuery& query, const std::vector<Eigen::Vector3d>& points) {
  std::vector<char> inside(points.size(), 0);
  const Aabb& box = query.hull_box();
  for (size_t k = 0; k < points.size(); ++k)
    inside[k] = box.Contains(points[k]) && query.Inside(points[k]);
  return inside;
}

}  // namespace hullpipe
