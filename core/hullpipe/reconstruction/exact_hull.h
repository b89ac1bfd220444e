// Exact ray–hull intersection (image-based visual hull, Matusik et al. 2000): for
// a ray, the exact set of parameters where it lies inside the visual hull as the
// cameras' object-pixel maps define it. The yardstick for the sweep's depth error.
//
// Per camera, the pixel a ray point falls on changes only where the projected ray
// crosses a pixel-grid line, the image border, the camera's z = 0 plane or its
// distortion's valid radius. For an undistorted camera u(s) and v(s) are Möbius
// functions of the ray parameter s (monotonic where z > 0), so every crossing has a
// closed form. With lens distortion the crossings are found by stepping at most a
// quarter pixel and bisecting each change to 1e-12 m; a pixel the projected curve
// enters and leaves within one step (a corner cut by less than ~0.25 px) can be
// missed, which is documented, not exact.
#pragma once

#include <utility>
#include <vector>

#include <Eigen/Core>

#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe {

/// Closed intervals [first, second] of the ray parameter, sorted and disjoint.
using Intervals = std::vector<std::pair<double, double>>;

/// A piece [s0, s1] of a ray on which one camera's vote is constant.
struct VoteSegment {
  double s0, s1;
  Vote vote;
};

/// Camera `camera`'s votes along origin + s * dir, s in [s_min, s_max]: sorted
/// pieces covering the range, neighbours of equal vote merged. Unseen where the
/// point is behind the camera, outside its image or its valid distortion radius.
std::vector<VoteSegment> RayCameraSegments(const VolumeQuery& query, size_t camera, const Eigen::Vector3d& origin,
                                           const Eigen::Vector3d& dir, double s_min, double s_max);

/// Where the ray origin + s * dir (world metres; dir need not be unit) with s in
/// [s_min, s_max] lies inside the hull of `query`, under the query's out-of-view
/// policy and inside the workspace: exactly the points VolumeQuery::Inside
/// accepts. Boundaries are exact to 1e-12 in s (undistorted cameras).
Intervals RayHullIntervals(const VolumeQuery& query, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                           double s_min, double s_max);

/// Same for one camera of the query: where the ray projects onto its object pixels.
Intervals RayCameraIntervals(const VolumeQuery& query, size_t camera, const Eigen::Vector3d& origin,
                             const Eigen::Vector3d& dir, double s_min, double s_max);

/// Intersection of two interval sets.
Intervals IntersectIntervals(const Intervals& a, const Intervals& b);

/// Exact first-hit eye depth (metres) of every pixel of `tile` of the view
/// (CV_32FC1, kNoDepth where the pixel centre's ray misses the hull), within the
/// hull box. The reference for the sweep's depth error. threads >= 1.
cv::Mat ExactHullDepth(const VolumeQuery& query, const struct NovelView& view, const cv::Rect& tile,
                       int threads = 1);

}  // namespace hullpipe
