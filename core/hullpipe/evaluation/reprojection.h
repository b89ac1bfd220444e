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

/// Intersection over union of two CV_8UC1 masks of one size (non-zero = set).
/// 1 when both are empty.
double MaskIoU(const cv::Mat& a, const cv::Mat& b);

}  // namespace hullpipe
