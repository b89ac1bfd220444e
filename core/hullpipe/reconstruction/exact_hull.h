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

#include <optional>
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

/// The hull's inside points on a grid of `step` metres over `region` (world),
/// blocks of 4x4x4 grid points the cameras prove empty skipped
/// (VolumeQuery::ProvesEmpty): the coarse samples that the CAD models' parts'
/// clearances share (models/part_bvh.h), and HullExtentAlong's first pass.
struct HullSamples {
  double step = 0.02;
  std::vector<Eigen::Vector3d> points;  ///< World metres, each VolumeQuery::Inside.
};
HullSamples SampleHull(const VolumeQuery& query, const Aabb& region, double step = 0.02);

/// How far the hull reaches along `dir` (world, any length): the largest
/// dir_hat . x over its points, e.g. its lowest point along gravity, where a
/// floor under the first hull goes (rig_world.h, `floor: hull`). The hull box's
/// corner is no answer where dir is not an axis (on a rig whose up is tilted it
/// lies below the hull by up to the box's half diagonal). The inside points of
/// a grid of `step` metres over the hull box (SampleHull; the step grows so the
/// grid has at most 200,000 points: a hull box as large as a room costs what a
/// person's does); the reach of the lines along dir through the 32 farthest
/// (point queries from where each line leaves the hull box back in steps of
/// step / 8, then bisection to 1e-7 m); then lines around the best one, 5 x 5 at
/// half the spacing each time down to step / 64 (an extreme point is often a
/// corner where silhouette cones meet). A hull point's reach, so never beyond
/// the hull's; a farther point more than ~2 steps from the best first line, or
/// a part thinner than step / 8 along dir beyond the point found, can be
/// missed. A hull the grid holds no
/// inside point of: the box's farthest corner. nullopt for an empty hull box.
/// Throws std::invalid_argument if step <= 0 or dir is zero.
std::optional<double> HullExtentAlong(const VolumeQuery& query, const Eigen::Vector3d& dir, double step = 0.02);

/// The hull's own axis-aligned box (world metres): the inside points of
/// HullExtentAlong's grid over the hull box (SampleHull, `step` grown so the
/// grid holds at most 200,000 points), one grid step beyond them on each side,
/// within the hull box. VolumeQuery::hull_box bounds the hull by the cameras'
/// object rectangles and the workspace: on a rig whose axes are not the
/// cameras' (a dome, a tilted world) some of its faces stay the workspace's,
/// tens of centimetres off; this one is within a step of the hull, except
/// where a part thinner than the step falls between grid points. Where the
/// centre of what the cameras see matters (the orbit, where balls aim). A hull
/// the grid holds no inside point of: the hull box. Empty for an empty hull box.
/// Throws std::invalid_argument if step <= 0.
Aabb SampledHullBox(const VolumeQuery& query, double step = 0.02);

/// Exact first-hit eye depth (metres) of every pixel of `tile` of the view
/// (CV_32FC1, kNoDepth where the pixel centre's ray misses the hull), within the
/// hull box. The reference for the sweep's depth error. threads >= 1.
cv::Mat ExactHullDepth(const VolumeQuery& query, const struct NovelView& view, const cv::Rect& tile,
                       int threads = 1);

}  // namespace hullpipe
