// Reprojecting a visual hull into a camera, to check it against that camera's
// object-pixel map (the hull built from all cameras reprojects inside every map;
// built from the others only, it shows how well they agree: leave-one-out).
#pragma once

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
/// hull. Each other camera's votes along the ray are found by walking its
/// projection with steps as long as the map's distance transform allows (a
/// uniform region in a few steps), quarter-pixel steps near a change of vote and
/// each change bisected (to 2^-14 of a step); like RayCameraSegments with lens
/// distortion, a pixel corner the projection cuts by less than ~0.25 px can be
/// missed. Both images in one pass: each ray is cut by the other cameras in turn
/// (stopping as soon as nothing is left), and camera `index` itself, whose vote
/// along its own ray is its map's pixel, is added last for `all`. Only rays
/// through the leave-one-out hull's box are walked, and of them only the parts
/// that enough pinhole cameras' frusta hold to make a point inside (the
/// query's required_seen(), camera `index` counted; cut in closed form, a
/// distorted camera's frustum taken as everything). threads >= 1.
Reprojection ReprojectHullExact(const VolumeQuery& query, size_t index, int threads = 2);

/// Intersection over union of two CV_8UC1 masks of one size (non-zero = set).
/// 1 when both are empty.
double MaskIoU(const cv::Mat& a, const cv::Mat& b);

}  // namespace hullpipe
