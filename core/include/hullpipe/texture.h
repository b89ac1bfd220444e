// Texturing the visual hull for the novel view (paper §3.3: "the hull is
// textured from the cameras that see it"): each hull pixel's 3D point is projected
// into the camera images and blended, favouring cameras whose viewing direction is
// closest to the user's.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/camera.h"
#include "hullpipe/plane_sweep.h"

namespace hullpipe {

/// One camera's colour image (CV_8UC3 BGR). Its size may differ from the camera's
/// calibrated size (reduced-resolution images): projection is scaled to it.
struct CameraImage {
  Camera camera;
  cv::Mat image;
};

/// Texturing settings.
struct TextureOptions {
  int max_cameras = 2;        ///< Blend at most this many best-aligned cameras (>= 1).
  double angle_power = 8.0;   ///< Weight = max(0, cos(angle between eye and camera rays))^power.
  void Check() const;
};

/// Colours the hull pixels of a depth tile (CV_32FC1 eye z, kNoDepth = none) at
/// `tile` of `view`. Returns CV_8UC3 of the tile's size, black where there is no
/// hull. Where no camera faces the eye's side of the point, the least oblique
/// camera colours it; a point no camera images stays mid-grey. No visibility
/// test yet (a later issue adds one): a camera whose view of the point is blocked
/// by another part of the hull may still contribute.
cv::Mat TextureHull(const cv::Mat& depth_tile, const cv::Rect& tile, const NovelView& view,
                    const std::vector<CameraImage>& images, const TextureOptions& options = {});

}  // namespace hullpipe
