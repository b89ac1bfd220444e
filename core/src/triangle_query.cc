#include "hullpipe/triangle_query.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace hullpipe {

void TriangleQueryOptions::Check() const {
  if (fixed_viewport < 0) throw std::invalid_argument("TriangleQueryOptions: fixed_viewport must be >= 0");
  if (fixed_viewport == 0 && !(max_pixel_size > 0))
    throw std::invalid_argument("TriangleQueryOptions: max_pixel_size must be > 0");
  if (max_viewport < 1) throw std::invalid_argument("TriangleQueryOptions: max_viewport must be >= 1");
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
    w = std::clamp(int(std::ceil(eu / o.max_pixel_size)), 1, o.max_viewport);
    h = std::clamp(int(std::ceil(ev / o.max_pixel_size)), 1, o.max_viewport);
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

bool PixelInTriangle(const TriangleViewport& vp, int i, int j) {
  const Eigen::Vector2d p(i + 0.5, j + 0.5);
  auto edge = [](const Eigen::Vector2d& s, const Eigen::Vector2d& e, const Eigen::Vector2d& q) {
    return (e.x() - s.x()) * (q.y() - s.y()) - (e.y() - s.y()) * (q.x() - s.x());
  };
  const double area = edge(vp.a2, vp.b2, vp.c2);
  if (area == 0) return false;
  const double sgn = area > 0 ? 1.0 : -1.0;
  return sgn * edge(vp.a2, vp.b2, p) >= 0 && sgn * edge(vp.b2, vp.c2, p) >= 0 &&
         sgn * edge(vp.c2, vp.a2, p) >= 0;
}

TriangleQueryResult QueryTriangleCpu(const VolumeQuery& query, const Eigen::Vector3d& a,
                                     const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                     const TriangleQueryOptions& o) {
  const TriangleViewport vp = MakeTriangleViewport(a, b, c, o);
  TriangleQueryResult result;
  for (int j = 0; j < vp.height; ++j) {
    for (int i = 0; i < vp.width; ++i) {
      if (!PixelInTriangle(vp, i, j)) continue;
      ++result.pixels_tested;
      const Eigen::Vector3d X = vp.origin + (i + 0.5) * vp.u_step + (j + 0.5) * vp.v_step;
      if (query.Inside(X)) result.collision_points.push_back(X);
    }
  }
  if (result.pixels_tested == 0) {
    result.pixels_tested = 1;
    const Eigen::Vector3d centroid = (a + b + c) / 3.0;
    if (query.Inside(centroid)) result.collision_points.push_back(centroid);
  }
  return result;
}

}  // namespace hullpipe
