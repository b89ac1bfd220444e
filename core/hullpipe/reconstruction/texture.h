// Texturing the visual hull for the novel view (paper §3.3: "the hull is
// textured from the cameras that see it"): each hull pixel's 3D point is projected
// into the camera images and blended, favouring cameras whose viewing direction is
// closest to the user's.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/geometry/camera.h"
#include "hullpipe/reconstruction/plane_sweep.h"

namespace hullpipe {

/// One camera's colour image (CV_8UC3 BGR). Its size may differ from the camera's
/// calibrated size (reduced-resolution images): projection is scaled to it.
struct CameraImage {
  Camera camera;
  cv::Mat image;
};

/// The part of a camera's colour image (image pixels, clipped to `image_size`)
/// that holds every pixel TextureHull or the GL texture pass reads for a point
/// the volume query finds inside the hull: a camera that sees such a point puts
/// it on one of its object pixels, so `object_rect` (the object pixels'
/// bounding rectangle in the map, VolumeQuery::object_rect) scaled from
/// `map_size` to `image_size`, grown by 2 image pixels (the bilinear
/// footprint's second texel and float rounding between the passes) and by one
/// map pixel. Empty for an empty `object_rect`. capture_node sends only this
/// part of each image (CameraImage's region; docs/gpu.md), the GL backend
/// uploads only it.
cv::Rect ImageRectAroundObjectPixels(const cv::Rect& object_rect, cv::Size map_size, cv::Size image_size);

/// Texturing settings.
struct TextureOptions {
  int max_cameras = 2;        ///< Blend at most this many best-aligned cameras (>= 1).
  double angle_power = 8.0;   ///< Weight = max(0, cos(angle between eye and camera rays))^power.
  /// Visibility test (with HullVisibility): a camera sees a hull point if the
  /// point's depth from it is at most the hull's depth there plus this bias
  /// (metres) plus two of its visibility pixels' footprints at that depth.
  double visibility_bias_m = 0.01;
  void Check() const;
};

/// The visual hull's depth seen from each camera: the first-hit depth map of a
/// pinhole view at the camera's pose and (scaled) intrinsics, from the same plane
/// sweep. A hull point hidden behind another part of the hull from a camera must
/// not take that camera's colour (paper §3.3; docs/benchmarks.md).
struct HullVisibility {
  std::vector<NovelView> views;  ///< One per camera, in the images' order.
  std::vector<cv::Mat> depth;    ///< CV_32FC1 eye-z depth of the hull from each.
};

/// The pinhole view a visibility map of `camera` is swept in: the camera's pose,
/// `width` pixels across, height and intrinsics scaled in proportion (lens
/// distortion left out).
NovelView HullVisibilityView(const Camera& camera, int width);

/// Sweeps the hull from each camera's viewpoint at `width` pixels across (height
/// in proportion; lens distortion is left out: the map is indexed by the pinhole
/// projection, which is what TextureHull looks up). planes / refine as for the
/// novel view. cameras[i] must be the query's camera i, or any calibrated camera.
/// Throws Interrupted once `stop` is set (PlaneSweepCpu).
HullVisibility ComputeHullVisibility(const VolumeQuery& query, const std::vector<Camera>& cameras, int width,
                                     const PlaneSweepOptions& sweep, int refine_iterations, int threads = 1,
                                     StopFlag stop = nullptr);

/// Colours the hull pixels of a depth tile (CV_32FC1 eye z, kNoDepth = none) at
/// `tile` of `view`. Returns CV_8UC3 of the tile's size, black where there is no
/// hull. Among the cameras that see a point (in their image and, with
/// `visibility`, not hidden by the hull: its images[i] must match views[i]) the
/// max_cameras best aligned with the eye are blended. Where no camera faces the
/// eye's side of the point, the least oblique visible camera colours it. Where the
/// test leaves no camera, the cameras that image the point are used as without
/// it (a guess, not a grey hole); a point no camera images stays mid-grey. Without
/// `visibility`, a camera whose view of the point is blocked by another part of
/// the hull may still contribute. Throws Interrupted once `stop` is set (polled
/// per row). The rows are shared by `threads` workers (>= 1; chunks of rows
/// handed out as each finishes), the colours the same on any number.
cv::Mat TextureHull(const cv::Mat& depth_tile, const cv::Rect& tile, const NovelView& view,
                    const std::vector<CameraImage>& images, const TextureOptions& options = {},
                    const HullVisibility* visibility = nullptr, StopFlag stop = nullptr, int threads = 1);

}  // namespace hullpipe
