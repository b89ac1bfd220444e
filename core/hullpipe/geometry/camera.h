// Pinhole camera with OpenCV's 5-parameter lens distortion (Brown–Conrady:
// k1, k2, p1, p2, k3) and a skew term in K, applied after distortion as
// Bouguet's and MATLAB's toolboxes and every decomposed 3x4 projection matrix
// give it (docs/rigs.md). Frames and pixel conventions: conventions.h.
#pragma once

#include <array>
#include <atomic>
#include <optional>
#include <string>

#include <Eigen/Core>

#include "hullpipe/geometry/rigid3.h"

namespace hullpipe {

/// Distortion coefficients in OpenCV order (k1, k2, p1, p2, k3); all zero = none.
using Distortion = std::array<double, 5>;

/// One calibrated camera. Intrinsics K are in hullpipe pixels (centres at +0.5).
struct Camera {
  /// Largest image side accepted (Check): 16384 px, a 268-Mpixel map, beyond any
  /// camera a rig uses; it bounds what a calibration file can make a node allocate.
  static constexpr int kMaxSide = 16384;
  int id = 0;                     ///< Camera id as on the wire (CameraInfo.camera_id).
  int width = 0, height = 0;      ///< Image size in pixels.
  double fx = 0, fy = 0;          ///< Focal lengths in pixels.
  double cx = 0, cy = 0;          ///< Principal point, hullpipe convention (+0.5).
  /// K's row 0, column 1 in pixels: u = fx x + skew y + cx on distorted
  /// normalized coordinates (x, y). Zero for OpenCV's and COLMAP's cameras.
  double skew = 0;
  Distortion distortion{};        ///< OpenCV k1 k2 p1 p2 k3 (unitless, normalized coords).
  Rigid3d cam_from_world;         ///< Extrinsics: world metres -> camera-frame metres.

  /// Throws std::invalid_argument naming the bad field if the camera is unusable
  /// (non-positive size or focal length, non-finite values, |skew| > fx,
  /// non-orthonormal R).
  void Check() const;

  /// True if any distortion coefficient is non-zero (else a pure pinhole).
  bool HasDistortion() const {
    for (double d : distortion)
      if (d != 0.0) return true;
    return false;
  }

  /// 3x3 intrinsic matrix K = [fx skew cx; 0 fy cy; 0 0 1] (hullpipe pixels).
  Eigen::Matrix3d K() const;

  /// K applied to distorted normalized coordinates: continuous pixel (u, v) =
  /// (fx x + skew y + cx, fy y + cy). Exact inverse: ImagePlaneFromPixel.
  Eigen::Vector2d PixelFromImagePlane(const Eigen::Vector2d& xd) const {
    return {fx * xd.x() + skew * xd.y() + cx, fy * xd.y() + cy};
  }

  /// K^-1 applied to a continuous pixel: distorted normalized coordinates
  /// y = (v - cy) / fy, x = (u - cx - skew y) / fx.
  Eigen::Vector2d ImagePlaneFromPixel(const Eigen::Vector2d& uv) const {
    const double y = (uv.y() - cy) / fy;
    return {(uv.x() - cx - skew * y) / fx, y};
  }

  /// Camera centre in world metres (-R^T t).
  Eigen::Vector3d Center() const;

  /// Applies lens distortion to normalized coordinates (x/z, y/z). OpenCV's model.
  /// Inline: the hull box search and the projections call it in hot loops.
  Eigen::Vector2d Distort(const Eigen::Vector2d& xn) const {
    const double k1 = distortion[0], k2 = distortion[1], p1 = distortion[2], p2 = distortion[3], k3 = distortion[4];
    const double x = xn.x(), y = xn.y();
    const double r2 = x * x + y * y;
    const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
    return {x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
            y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y};
  }

  /// Inverts Distort by Newton's method with the analytic Jacobian (converges to
  /// ~1e-15 inside the valid radius; cv::undistortPoints' fixed-point iteration
  /// leaves up to 1e-5 px there). At or beyond the fold of the radial polynomial
  /// there is no unique inverse: the last iterate is returned.
  Eigen::Vector2d Undistort(const Eigen::Vector2d& xd) const;

  /// Squared normalized radius beyond which the radial polynomial stops being
  /// monotonic: points farther out would fold back into the image, so they are
  /// reported as not projectable. +infinity where the polynomial never folds.
  /// Cached in the camera on the first call (Project makes it); safe to call
  /// from threads sharing the camera.
  double MaxValidRadius2() const;

  /// Projects a world point (metres) to continuous pixel coordinates. Returns
  /// nullopt if the point is not in front of the camera (z <= 1e-9 m) or is beyond
  /// the distortion's valid radius. The result may lie outside the image; test
  /// with InImage. Paper §3: the projection used by every volume query.
  std::optional<Eigen::Vector2d> Project(const Eigen::Vector3d& X_world) const;

  /// True if continuous pixel coordinates fall on a pixel of the image.
  bool InImage(const Eigen::Vector2d& uv) const {
    return uv.x() >= 0 && uv.y() >= 0 && uv.x() < width && uv.y() < height;
  }

  /// World-frame unit direction of the ray through continuous pixel (u, v), undoing
  /// distortion. The ray starts at Center().
  Eigen::Vector3d PixelRayWorld(const Eigen::Vector2d& uv) const;

 private:
  // MaxValidRadius2's cache (-1: not computed). Threads sharing a const
  // camera may fill it at once, each with the same value: relaxed atomic
  // loads and stores, copied with the camera.
  struct RadiusCache {
    std::atomic<double> value{-1};
    RadiusCache() = default;
    RadiusCache(const RadiusCache& o) : value(o.value.load(std::memory_order_relaxed)) {}
    RadiusCache& operator=(const RadiusCache& o) {
      value.store(o.value.load(std::memory_order_relaxed), std::memory_order_relaxed);
      return *this;
    }
  };
  mutable RadiusCache max_valid_radius2_;
};

/// Returns the Camera scaled to a new image size (intrinsics scaled: fx, skew
/// and cx by the width's ratio, fy and cy by the height's; distortion and
/// extrinsics kept): used when maps are published at reduced resolution.
Camera ScaledCamera(const Camera& camera, int new_width, int new_height);

}  // namespace hullpipe
