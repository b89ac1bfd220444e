// Reprojecting a visual hull into a camera, to check it against that camera's
// object-pixel map (the hull built from all cameras reprojects inside every map;
// built from the others only, it shows how well they agree: leave-one-out).
#pragma once

#include <memory>

#include <opencv2/core.hpp>

#include "hullpipe/geometry/camera.h"
#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe {

/// Reprojection of the hull of `query` into `camera`: pixel (c, r) is 255 iff the
/// ray through its centre (lens distortion undone) meets a point inside the hull,
/// searched within the hull box at `step` metres (a part thinner than step along
/// the ray may be missed). CV_8UC1 of the camera's size. threads >= 1.
cv::Mat ReprojectHull(const VolumeQuery& query, const Camera& camera, double step = 0.005, int threads = 2);

/// A camera's reprojections with and without itself (leave-one-out).
struct Reprojection {
  cv::Mat all;            ///< The hull of every camera of the query, reprojected (CV_8UC1, 0/255).
  cv::Mat leave_one_out;  ///< The hull of the other cameras only.
};

/// Reprojection into camera `index` of `query` by ray–hull intervals (the
/// image-based visual hull, Matusik et al. 2000; exact_hull.h), not a march at a
/// fixed step: pixel (c, r) is set iff the ray through its centre meets the
/// hull, for the hull of every camera (`all`) and of the others only
/// (`leave_one_out`), in one pass.
///
/// Cells of camera `index`'s frustum (a tile of pixels times a depth range),
/// coarse first, are decided whole where one other camera sees only background
/// over the cell's projection, where too few cameras see any of it to make a
/// point inside (kUnknown's min_seen: for a pixel on camera `index`'s own
/// background only the leave-one-out hull can hold it, so camera `index` is not
/// counted there), or where every other camera sees only object; a cell that is
/// none of these is split down to one pixel. Each pixel left is walked only
/// over the depths where its cells stayed mixed, and only over the parts of its
/// ray that enough pinhole frusta hold (cut in closed form). Each other
/// camera's votes along the ray come from walking its projection: for a
/// pinhole, steps as long as the map's distance transform allows, and near a
/// change every pixel line the projection crosses solved in closed form (as
/// RayHullIntervals does: the same pixels, test ReprojectionExact); for a
/// distorted camera, quarter-pixel steps near a change, each bisected to 2^-14
/// of a step, so a pixel corner it cuts by under ~0.25 px can be missed (as
/// RayCameraSegments may). threads >= 1 (rows of 32-px tiles handed out as
/// threads free up).
Reprojection ReprojectHullExact(const VolumeQuery& query, size_t index, int threads = 2);

/// ReprojectHullExact for every camera of one query: each camera's distance
/// transform and integral image are found once, in the constructor, not once per
/// reprojection (a 20-camera rig reprojects each map 19 times). `query` must
/// outlive the reprojector. Throws std::invalid_argument if threads < 1.
class ExactReprojector {
 public:
  explicit ExactReprojector(const VolumeQuery& query, int threads = 2);
  ~ExactReprojector();
  ExactReprojector(const ExactReprojector&) = delete;
  ExactReprojector& operator=(const ExactReprojector&) = delete;

  /// ReprojectHullExact(query, index, threads). Throws std::out_of_range for an
  /// index past the query's cameras, std::invalid_argument if threads < 1.
  Reprojection Reproject(size_t index, int threads = 2) const;

 private:
  struct Impl;
  const VolumeQuery& q_;
  std::unique_ptr<const Impl> impl_;
};

/// Intersection over union of two CV_8UC1 masks of one size (non-zero = set).
/// 1 when both are empty.
double MaskIoU(const cv::Mat& a, const cv::Mat& b);

}  // namespace hullpipe
