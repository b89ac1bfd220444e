#include "hullpipe/geometry/aabb.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>


namespace hullpipe {

std::vector<Eigen::Vector3d> Aabb::Corners() const {
  std::vector<Eigen::Vector3d> c;
  for (int i = 0; i < 8; ++i)
    c.emplace_back(i & 1 ? max.x() : min.x(), i & 2 ? max.y() : min.y(), i & 4 ? max.z() : min.z());
  return c;
}

bool Aabb::ClipRay(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double* s0,
                   double* s1) const {
  if (empty()) return false;
  double lo = *s0, hi = *s1;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-300) {
      if (o[a] < min[a] || o[a] > max[a]) return false;
      continue;
    }
    double t0 = (min[a] - o[a]) / d[a], t1 = (max[a] - o[a]) / d[a];
    if (t0 > t1) std::swap(t0, t1);
    lo = std::max(lo, t0);
    hi = std::min(hi, t1);
    if (lo > hi) return false;
  }
  *s0 = lo;
  *s1 = hi;
  return true;
}

Aabb DefaultWorkspace(const std::vector<Camera>& cameras) {
  Aabb box;
  for (const auto& c : cameras) box.Extend(c.Center());
  if (box.empty()) return box;
  const double grow = 0.5 * (box.max - box.min).maxCoeff() + 0.5;
  box.min.array() -= grow;
  box.max.array() += grow;
  return box;
}

namespace {

// Convex polytope as a list of faces, each a vertex loop.
using Face = std::vector<Eigen::Vector3d>;

std::vector<Face> BoxFaces(const Aabb& b) {
  const auto c = b.Corners();
  // Corner index bits: x=1, y=2, z=4.
  const int idx[6][4] = {{0, 2, 6, 4}, {1, 5, 7, 3}, {0, 4, 5, 1},
                         {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 6, 7, 5}};
  std::vector<Face> faces;
  for (const auto& f : idx) faces.push_back({c[f[0]], c[f[1]], c[f[2]], c[f[3]]});
  return faces;
}

// Appends p unless it is (within 1e-12 m) the last point or one of `all`.
void PushDistinct(std::vector<Eigen::Vector3d>* pts, const Eigen::Vector3d& p, bool all) {
  constexpr double kSame2 = 1e-24;
  if (all) {
    for (const auto& q : *pts)
      if ((q - p).squaredNorm() <= kSame2) return;
  } else if (!pts->empty() && (pts->back() - p).squaredNorm() <= kSame2) {
    return;
  }
  pts->push_back(p);
}

// Keeps the part of the polytope where n.x + d >= 0. Every cut edge is shared
// by two faces and gives its point to the cap twice, and a vertex on the plane
// comes back as its own cut: points are kept once, or a rig of many cameras
// (5 planes each) grew its faces' loops with every plane (the hull box's set-up
// was ~n^2 in the cameras: docs/benchmarks.md, "Many cameras").
std::vector<Face> ClipPolytope(const std::vector<Face>& faces, const Eigen::Vector3d& n,
                               double d) {
  bool cuts = false;  // most planes leave the polytope whole: no copy then
  for (const Face& f : faces) {
    for (const auto& a : f)
      if (n.dot(a) + d < -1e-12) {
        cuts = true;
        break;
      }
    if (cuts) break;
  }
  if (!cuts) return faces;
  std::vector<Face> out;
  std::vector<Eigen::Vector3d> cap;
  const double eps = 1e-12;
  for (const Face& f : faces) {
    Face clipped;
    for (size_t i = 0; i < f.size(); ++i) {
      const Eigen::Vector3d& a = f[i];
      const Eigen::Vector3d& b = f[(i + 1) % f.size()];
      const double da = n.dot(a) + d, db = n.dot(b) + d;
      if (da >= -eps) PushDistinct(&clipped, a, false);
      if ((da >= -eps) != (db >= -eps)) {
        const Eigen::Vector3d p = a + (b - a) * (da / (da - db));
        PushDistinct(&clipped, p, false);
        PushDistinct(&cap, p, true);
      }
    }
    if (clipped.size() >= 2 && (clipped.front() - clipped.back()).squaredNorm() <= 1e-24) clipped.pop_back();
    if (clipped.size() >= 3) out.push_back(std::move(clipped));
  }
  if (cap.size() >= 3) {
    // Order the cap's points by angle around their centroid in the plane.
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const auto& p : cap) centroid += p;
    centroid /= double(cap.size());
    const Eigen::Vector3d u = n.unitOrthogonal(), v = n.normalized().cross(u);
    std::sort(cap.begin(), cap.end(), [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
      return std::atan2((a - centroid).dot(v), (a - centroid).dot(u)) <
             std::atan2((b - centroid).dot(v), (b - centroid).dot(u));
    });
    out.push_back(std::move(cap));
  }
  return out;
}

}  // namespace

Aabb HullBoundingBox(const std::vector<Camera>& cameras, const std::vector<cv::Mat>& maps,
                     const Aabb& workspace) {
  if (cameras.size() != maps.size()) return {};
  std::vector<cv::Rect> rects;
  for (const cv::Mat& m : maps) {
    CV_Assert(m.type() == CV_8UC1);
    rects.push_back(cv::boundingRect(m));  // the object pixels' bounding rectangle
  }
  return HullBoundingBox(cameras, rects, workspace);
}

ObjectPyramid MakeObjectPyramid(const Camera& cam, const cv::Rect& r) {
  ObjectPyramid out;
  if (r.area() == 0) {
    out.empty = true;
    return out;
  }
  // Undistorted extremes of the rectangle's border, in normalized coordinates
  // (with skew the rectangle is a parallelogram there: its box holds it).
  double a0 = 1e300, a1 = -1e300, b0 = 1e300, b1 = -1e300;
  auto visit = [&](double u, double v) {
    const Eigen::Vector2d xn = cam.Undistort(cam.ImagePlaneFromPixel({u, v}));
    a0 = std::min(a0, xn.x());
    a1 = std::max(a1, xn.x());
    b0 = std::min(b0, xn.y());
    b1 = std::max(b1, xn.y());
  };
  const double x0 = r.x, x1 = r.x + r.width, y0 = r.y, y1 = r.y + r.height;
  for (double u = x0;; u = std::min(u + 4.0, x1)) {
    visit(u, y0);
    visit(u, y1);
    if (u >= x1) break;
  }
  for (double v = y0;; v = std::min(v + 4.0, y1)) {
    visit(x0, v);
    visit(x1, v);
    if (v >= y1) break;
  }
  // Margin for the sampling of a curved border: 1 px in normalized units.
  const double m = 1.0 / std::min(cam.fx, cam.fy);
  a0 -= m, a1 += m, b0 -= m, b1 += m;
  // Half-spaces n_c . X_c >= 0 in the camera frame, then in world coordinates.
  const Eigen::Vector3d normals_c[5] = {{1, 0, -a0}, {-1, 0, a1}, {0, 1, -b0}, {0, -1, b1}, {0, 0, 1}};
  const Eigen::Matrix3d& R = cam.cam_from_world.rotation;
  const Eigen::Vector3d& t = cam.cam_from_world.translation;
  for (size_t k = 0; k < 5; ++k) {
    out.normal[k] = R.transpose() * normals_c[k];
    out.offset[k] = normals_c[k].dot(t) - (k == 4 ? 1e-3 : 0.0);
  }
  return out;
}

Aabb PyramidsBox(const std::vector<const ObjectPyramid*>& pyramids, const Aabb& workspace) {
  if (workspace.empty()) return {};
  for (const ObjectPyramid* p : pyramids)
    if (p->empty) return {};
  std::vector<Face> poly = BoxFaces(workspace);
  for (const ObjectPyramid* p : pyramids)
    for (size_t k = 0; k < 5; ++k) {
      poly = ClipPolytope(poly, p->normal[k], p->offset[k]);
      if (poly.empty()) return {};
    }
  Aabb box;
  for (const auto& f : poly)
    for (const auto& q : f) box.Extend(q);
  return box;
}

Aabb HullBoundingBox(const std::vector<Camera>& cameras, const std::vector<cv::Rect>& object_rects,
                     const Aabb& workspace) {
  if (workspace.empty() || cameras.size() != object_rects.size()) return {};
  std::vector<ObjectPyramid> pyramids;
  for (size_t i = 0; i < cameras.size(); ++i) {
    pyramids.push_back(MakeObjectPyramid(cameras[i], object_rects[i]));
    if (pyramids.back().empty) return {};
  }
  std::vector<const ObjectPyramid*> all;
  for (const auto& p : pyramids) all.push_back(&p);
  return PyramidsBox(all, workspace);
}

}  // namespace hullpipe
