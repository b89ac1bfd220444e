// Rendering error on real input, as image-based rendering papers measure it:
// the textured hull of the other cameras, rendered from a held-out camera's pose,
// against that camera's real image inside its object-pixel map (the paper's
// "rendering error", §5, measured without a ground-truth model; docs/benchmarks.md,
// "Held-out rendering").
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/geometry/aabb.h"
#include "hullpipe/geometry/camera.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/texture.h"
#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe {

/// A camera's real image and object-pixel map resampled to the pinhole camera
/// of the same K (lens distortion removed), so that a pinhole rendering at the
/// camera's pose compares with them pixel for pixel.
struct PinholeTruth {
  NovelView view;  ///< The camera's pose, size and K, without distortion.
  cv::Mat image;   ///< CV_8UC3: bilinear; black where the pinhole pixel maps off the image.
  cv::Mat map;     ///< CV_8UC1 0/255: nearest pixel; 0 off the image.
};

/// Resamples `image` (CV_8UC3) and `map` (CV_8UC1) of `camera`, both of the
/// camera's calibrated size, to its pinhole view (fx, fy, cx, cy, no skew):
/// pinhole pixel centre (c+0.5, r+0.5) takes the camera's pixel at
/// K·Distort(K0^-1 (c+0.5, r+0.5, 1)), K with the camera's skew, K0 without
/// (hullpipe pixel centres; geometry/conventions.h). Pixels beyond the
/// distortion's valid radius (Camera::MaxValidRadius2) are black / 0. Without
/// distortion and skew the result equals the input. Throws std::invalid_argument on a type or size mismatch.
PinholeTruth UndistortToPinhole(const Camera& camera, const cv::Mat& image, const cv::Mat& map);

/// Colour error of `rendered` against `truth` (both CV_8UC3 of one size) over the
/// pixels of `mask` (CV_8UC1, non-zero = counted).
struct ImageError {
  /// 10 log10(255^2 / MSE), MSE over the masked pixels' three channels; capped at
  /// kMaxPsnrDb (identical images, or no masked pixel).
  double psnr_db = 0;
  /// Structural similarity (Wang et al. 2004; OpenCV's cv::quality::QualitySSIM,
  /// 11x11 Gaussian window, sigma 1.5) of the two images with everything outside
  /// the mask set to black, its map averaged over the masked pixels and channels:
  /// 1 = identical. A window at the mask's border also sees black on both sides.
  double ssim = 1;
  int64_t pixels = 0;  ///< Masked pixels.
  static constexpr double kMaxPsnrDb = 100;
};
/// Throws std::invalid_argument on a type or size mismatch.
ImageError MaskedImageError(const cv::Mat& truth, const cv::Mat& rendered, const cv::Mat& mask);

/// How the held-out view is rendered: the plane sweep and texturing the recon
/// node uses (PlaneSweepCpu, TextureHull), their settings here.
struct HeldOutOptions {
  PlaneSweepOptions sweep;      ///< Planes fitted to the hull box (the node's default).
  int refine_iterations = 6;    ///< As recon_node --refine.
  TextureOptions texture;       ///< max_cameras 1: nearest camera; 2+: blended.
  /// Width of each camera's hull depth map for the visibility test
  /// (ComputeHullVisibility); 0: no visibility test. recon_node uses 80.
  int visibility_width = 0;
  int threads = 2;              ///< >= 1.
  /// Throws std::invalid_argument naming the bad field.
  void Check() const;
};

/// One camera held out.
struct HeldOutResult {
  PinholeTruth truth;  ///< The held-out camera's real image and map, undistorted.
  cv::Mat rendered;    ///< CV_8UC3 textured hull of the others at its pose; black where no hull.
  cv::Mat hull;        ///< CV_8UC1 0/255: pixels with hull (finite depth).
  /// Colour error over the held-out camera's object pixels (a pixel of the map
  /// the hull misses counts, black against the real colour).
  ImageError error;
  /// The same over the object pixels the hull covers (map and hull): the
  /// texturing's error where there is geometry to texture.
  ImageError error_covered;
  /// Silhouette IoU of `hull` with truth.map (the leave-one-out IoU, resampled
  /// to the pinhole).
  double iou = 0;
};

/// Renders the visual hull of every camera but `held_out` (volume query over
/// their maps within `workspace`; paper §3.2–3.3) from camera `held_out`'s pose
/// at its calibrated size and K, textures it from the other cameras' images
/// (TextureHull, with the visibility test if asked), and compares it with the
/// held-out camera's undistorted image inside its undistorted map. views[i] and
/// images[i] (CV_8UC3, the camera's size) belong to one camera; at least three
/// cameras (a hull from two is a wedge, not a test). Throws std::invalid_argument
/// on a size or count mismatch.
HeldOutResult RenderHeldOut(const std::vector<CameraMap>& views, const std::vector<cv::Mat>& images,
                            const Aabb& workspace, size_t held_out, const HeldOutOptions& options = {});

}  // namespace hullpipe
