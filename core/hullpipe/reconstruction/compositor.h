// Compositing the hull with the virtual scene for the novel view (paper §3.3,
// §4: "colliding objects are drawn red"): per pixel, the nearest of the hull, the
// virtual objects and the floor wins (a depth test on eye z).
#pragma once

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "hullpipe/pipeline/messages.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/util/interrupt.h"

namespace hullpipe {

/// A virtual sphere to draw (world metres).
struct VirtualSphere {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 0.1;
  bool colliding = false;  ///< Drawn red when true.
};

/// Compositing settings.
struct CompositeOptions {
  bool draw_floor = true;
  Eigen::Vector3d floor_normal{0, 0, -1};  ///< Unit normal pointing up (Utrecht: -z).
  double floor_offset = 0.0;               ///< Floor plane: floor_normal . x = offset.
  cv::Vec3b ball_colour{220, 180, 40};     ///< BGR when not colliding.
  cv::Vec3b collide_colour{30, 30, 230};   ///< BGR when colliding (red).
};

/// The meshes to draw, by pointer: a CAD model's parts are drawn every frame
/// from geometry the caller keeps (no copy per frame).
using MeshDraws = std::vector<const VirtualMeshDraw*>;

/// A box state (VirtualObjectSample kBox) as the triangles Composite draws: its
/// 12 faces' triangles at position, turned by orientation, all drawn red while
/// it collides, else in `colour` (BGR).
VirtualMeshDraw BoxDraw(const VirtualObjectSample& box, const cv::Vec3b& colour);

/// Draws the view: hull_depth (CV_32FC1 eye z, kNoDepth = none) and hull_colour
/// (CV_8UC3), both of the view's size, with the spheres, meshes (rasterised,
/// two-sided, flat-shaded; points as discs) and floor, depth-tested on eye z.
/// Returns CV_8UC3 BGR of the view's size. *depth_out (optional) receives the
/// composited eye-z depth. A mesh whose triangle indices are out of range is
/// skipped (callers validate messages first); null pointers are skipped. A
/// triangle is tested only at the pixel centres inside its box (most of a CAD
/// model's triangles, smaller than a pixel, cover none). `stop` (util/interrupt.h)
/// is polled per row and every 1024 triangles: once set, throws Interrupted (an
/// 8192x8192 view takes seconds; a node stops within a second of SIGINT).
cv::Mat Composite(const NovelView& view, const cv::Mat& hull_depth, const cv::Mat& hull_colour,
                  const std::vector<VirtualSphere>& spheres, const CompositeOptions& options = {},
                  cv::Mat* depth_out = nullptr, const MeshDraws& meshes = {}, StopFlag stop = nullptr);

/// The scripted head path: an orbit around `centre` (world metres) of `radius` at
/// `height` along the up vector, one turn per `period` seconds, looking at centre.
struct OrbitPath {
  Eigen::Vector3d centre{0.35, 0.05, -0.9};
  Eigen::Vector3d up{0, 0, -1};
  double radius = 3.0;
  double height = 0.6;  ///< Eye height above the centre, metres.
  double period = 12.0;
  double phase = 0.0;   ///< Start angle, radians.
  /// world_from_eye at time t seconds.
  Rigid3d WorldFromEye(double t) const;
};

}  // namespace hullpipe
