// Axis-aligned boxes in world metres, and the visual hull's bounding box from the
// object-pixel maps (paper §4.1: "bounding box test first").
#pragma once

#include <array>
#include <cmath>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "hullpipe/geometry/camera.h"

namespace hullpipe {

/// Closed axis-aligned box [min, max] in world metres. Empty when any min > max.
struct Aabb {
  Eigen::Vector3d min = Eigen::Vector3d::Constant(1.0);
  Eigen::Vector3d max = Eigen::Vector3d::Constant(-1.0);

  bool empty() const { return (min.array() > max.array()).any(); }
  bool Contains(const Eigen::Vector3d& p) const {
    return !empty() && (p.array() >= min.array()).all() && (p.array() <= max.array()).all();
  }
  bool Intersects(const Aabb& o) const {
    return !empty() && !o.empty() && (min.array() <= o.max.array()).all() &&
           (o.min.array() <= max.array()).all();
  }
  /// The box common to this one and `o` (empty when they do not meet).
  Aabb Intersection(const Aabb& o) const {
    Aabb r;
    r.min = min.cwiseMax(o.min);
    r.max = max.cwiseMin(o.max);
    return r;
  }
  void Extend(const Eigen::Vector3d& p) {
    if (empty()) {
      min = max = p;
    } else {
      min = min.cwiseMin(p);
      max = max.cwiseMax(p);
    }
  }
  Eigen::Vector3d Center() const { return 0.5 * (min + max); }
  /// The 8 corners (empty box: unspecified).
  std::vector<Eigen::Vector3d> Corners() const;
  /// Ray–box slab test for points origin + s*dir with s in [s_min, s_max]. On a hit
  /// narrows [*s0, *s1] to the part inside the box and returns true.
  bool ClipRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double* s0,
               double* s1) const;
};

/// Calls f(point) for every point min + (i, j, k) * step of a grid over `box`
/// (world metres), i in [0, floor(size.x / step)] and likewise j, k; x fastest.
/// Nothing for an empty box. step must be > 0.
template <typename F>
void ForEachGridPoint(const Aabb& box, double step, F&& f) {
  if (box.empty()) return;
  const Eigen::Vector3d size = box.max - box.min;
  const int nx = int(std::floor(size.x() / step)) + 1, ny = int(std::floor(size.y() / step)) + 1,
            nz = int(std::floor(size.z() / step)) + 1;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) f(Eigen::Vector3d(box.min + Eigen::Vector3d(i * step, j * step, k * step)));
}

/// A workspace that surely contains what the cameras watch when nothing else is
/// known: the box of the camera centres grown by half its largest side on every side.
Aabb DefaultWorkspace(const std::vector<Camera>& cameras);

/// Bounding box of the visual hull inside `workspace`: each camera's silhouette
/// bounding rectangle is back-projected to a pyramid (4 planes through the camera
/// centre, plus z > 0), the pyramids are intersected with the workspace as a convex
/// polytope, and the polytope's box is returned. Conservative: every point inside
/// the hull (and the workspace) is inside the box. Lens distortion is handled by
/// undistorting the rectangle's border (sampled every 4 px) and keeping its
/// extremes. An empty map in any camera gives an empty box.
/// maps[i] belongs to cameras[i] (CV_8UC1, size of the camera).
Aabb HullBoundingBox(const std::vector<Camera>& cameras, const std::vector<cv::Mat>& maps,
                     const Aabb& workspace);

/// The same from each map's object-pixel bounding rectangle (cv::boundingRect of
/// maps[i]; an empty rectangle: no object pixel), for callers that bound many
/// subsets of one set of cameras and so find each rectangle once.
Aabb HullBoundingBox(const std::vector<Camera>& cameras, const std::vector<cv::Rect>& object_rects,
                     const Aabb& workspace);

/// What one camera's object-pixel rectangle can hold: five world half-spaces
/// normal[k] . X + offset[k] >= 0 (the rectangle's four sides back-projected
/// through the camera centre, undistorted as HullBoundingBox says, and z > 1 mm
/// in front). `empty`: the rectangle has no pixel. Found once per camera by
/// callers that bound many subsets of one set of cameras (the kUnknown hull
/// box unions the boxes of every camera subset that may see a point).
struct ObjectPyramid {
  std::array<Eigen::Vector3d, 5> normal;
  std::array<double, 5> offset{};
  bool empty = false;
};
ObjectPyramid MakeObjectPyramid(const Camera& camera, const cv::Rect& object_rect);

/// The box of the workspace intersected with the pyramids (HullBoundingBox's
/// polytope); empty if any pyramid is, or the intersection is.
Aabb PyramidsBox(const std::vector<const ObjectPyramid*>& pyramids, const Aabb& workspace);

}  // namespace hullpipe
