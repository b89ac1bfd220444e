// Volume querying (paper §3.2): a 3D point is inside the visual hull iff it
// projects onto an object pixel in every one of the n cameras' object-pixel maps.
// This is the CPU reference that every other path (GL sweep, GL triangle query)
// is tested against.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "hullpipe/aabb.h"
#include "hullpipe/camera.h"

namespace hullpipe {

/// One camera's calibration with its object-pixel map for one frame
/// (CV_8UC1, camera.width x camera.height, non-zero = object).
struct CameraMap {
  Camera camera;
  cv::Mat map;
};

namespace detail {
/// A camera's projection reduced to floats for hot loops (see VolumeQuery::Hits).
struct FastCamera {
  float r[9], t[3];
  float fx, fy, cx, cy;
  float k1, k2, p1, p2, k3;
  float r2max;
  bool distorted;
  int width, height;
  const uint8_t* data;
  size_t step;
};
}  // namespace detail

/// The visual hull of one frameset, queryable point by point.
/// Points outside a camera's image (or behind it) are outside the hull, as in the
/// paper; points outside the workspace box are outside too.
class VolumeQuery {
 public:
  /// views: the n cameras and their maps (n >= 1). workspace: world box (metres)
  /// outside which nothing is hull (DefaultWorkspace if unsure). Computes the hull's
  /// bounding box (HullBoundingBox). Throws std::invalid_argument if a map is not
  /// CV_8UC1 of its camera's size, or n == 0. The maps are shared, not copied.
  VolumeQuery(std::vector<CameraMap> views, const Aabb& workspace);

  /// Number of cameras n.
  size_t size() const { return views_.size(); }
  const std::vector<CameraMap>& views() const { return views_; }
  const Aabb& workspace() const { return workspace_; }
  /// Conservative box of the hull (empty if some map is empty).
  const Aabb& hull_box() const { return hull_box_; }

  /// True iff X (world metres) projects onto object pixels in all n cameras and
  /// lies in the workspace. §3.2 eq. "inside iff count == n".
  bool Inside(const Eigen::Vector3d& X_world) const;

  /// Number of cameras in which X projects onto an object pixel (0..n); the
  /// stencil count of the paper's sweep.
  int Count(const Eigen::Vector3d& X_world) const;

  /// A query over the cameras whose indices are listed (for leave-one-out tests).
  VolumeQuery Subset(const std::vector<int>& indices) const;

  /// Float camera parameters for hot loops, in views() order.
  const std::vector<detail::FastCamera>& fast() const { return fast_; }

  /// True iff camera-frame point (x, y, z) of camera `c` projects onto an object
  /// pixel of its map. Inline for the sweep's inner loop.
  static bool Hits(const detail::FastCamera& c, float x, float y, float z) {
    if (!(z > 1e-6f)) return false;
    const float iz = 1.0f / z;
    float xn = x * iz, yn = y * iz;
    const float r2 = xn * xn + yn * yn;
    if (r2 > c.r2max) return false;
    if (c.distorted) {
      const float radial = 1.0f + r2 * (c.k1 + r2 * (c.k2 + r2 * c.k3));
      const float xy = xn * yn;
      const float xd = xn * radial + 2.0f * c.p1 * xy + c.p2 * (r2 + 2.0f * xn * xn);
      const float yd = yn * radial + c.p1 * (r2 + 2.0f * yn * yn) + 2.0f * c.p2 * xy;
      xn = xd;
      yn = yd;
    }
    const float u = c.fx * xn + c.cx, v = c.fy * yn + c.cy;
    if (!(u >= 0.0f && v >= 0.0f && u < float(c.width) && v < float(c.height))) return false;
    return c.data[size_t(v) * c.step + size_t(u)] != 0;
  }

 private:
  std::vector<CameraMap> views_;
  Aabb workspace_;
  Aabb hull_box_;
  std::vector<detail::FastCamera> fast_;
};

}  // namespace hullpipe
