#include "hullpipe/geometry/camera.h"

#include <cmath>

#include <gtest/gtest.h>

#include "hullpipe/geometry/calibration.h"
#include "hullpipe/evaluation/synthetic.h"

namespace hullpipe {
namespace {

Camera DistortedCamera() {
  // The Utrecht rig's cam1 distortion: strong barrel (k1 = -0.37).
  auto cams = RingCameras(1, 4.0, 2.0, Eigen::Vector3d(0, 0, -1), 644, 486, 1.2,
                          Distortion{-0.3687, 0.2032, 3.3e-4, 1.8e-5, -0.0712});
  return cams[0];
}

TEST(Camera, ProjectUnprojectRoundTripWithDistortion) {
  const Camera cam = DistortedCamera();
  cam.Check();
  // A grid over the central 90% of the image: its ray, a point on it, projected
  // back, lands on it. (With this distortion the image corners lie at the fold of
  // the radial polynomial, as the real cam1's do: there is no unique ray there.)
  // Tolerance 1e-6 px: Undistort iterates to ~1e-9 in normalized units (f ~ 300 px).
  for (double v = 0.05 * cam.height; v <= 0.95 * cam.height; v += 23.7)
    for (double u = 0.05 * cam.width; u <= 0.95 * cam.width; u += 21.3) {
      const Eigen::Vector2d uv(u, v);
      const Eigen::Vector3d X = cam.Center() + 3.7 * cam.PixelRayWorld(uv);
      const auto back = cam.Project(X);
      ASSERT_TRUE(back.has_value());
      EXPECT_NEAR((*back - uv).norm(), 0.0, 1e-6) << "pixel " << u << "," << v;
    }
}

TEST(Camera, PointBehindCameraIsNotProjected) {
  const Camera cam = DistortedCamera();
  const Eigen::Vector3d forward = cam.cam_from_world.rotation.row(2).transpose();
  EXPECT_TRUE(cam.Project(cam.Center() + forward).has_value());
  EXPECT_FALSE(cam.Project(cam.Center() - forward).has_value());  // never mirrored
  EXPECT_FALSE(cam.Project(cam.Center()).has_value());            // at the centre
}

TEST(Camera, DistortionFoldBackIsRejected) {
  const Camera cam = DistortedCamera();
  const double r2 = cam.MaxValidRadius2();
  ASSERT_TRUE(std::isfinite(r2));
  // Beyond the valid radius the polynomial folds back into the image: such a
  // point must not be reported as projecting anywhere.
  const Eigen::Vector3d X_cam(std::sqrt(r2) * 1.2, 0, 1);
  const Eigen::Vector3d X = cam.cam_from_world.Inverse() * X_cam;
  EXPECT_FALSE(cam.Project(X).has_value());
  const Eigen::Vector3d inside_cam(std::sqrt(r2) * 0.9, 0, 1);
  EXPECT_TRUE(cam.Project(cam.cam_from_world.Inverse() * inside_cam).has_value());
}

// The valid radius is the first zero of d/dr [r (1 + k1 r^2 + k2 r^4 + k3 r^6)]
// = 1 + 3 k1 s + 5 k2 s^2 + 7 k3 s^3 (s = r^2), against closed forms: a line, a
// quadratic, one that never folds (the published dome's lens), and one whose
// slope only touches zero at s = 1 ((1 - s)^2), which a scan can step over.
TEST(Camera, ValidRadiusIsTheSlopesFirstZero) {
  auto r2 = [](double k1, double k2, double k3) {
    Camera c = DistortedCamera();
    c.distortion = {k1, k2, 0, 0, k3};
    return c.MaxValidRadius2();
  };
  EXPECT_NEAR(r2(-0.5, 0, 0), 2.0 / 3.0, 1e-12);                                   // 1 - 1.5 s
  EXPECT_NEAR(r2(0.1, -0.05, 0), (0.3 + std::sqrt(0.09 + 1.0)) / 0.5, 1e-12);      // 1 + 0.3 s - 0.25 s^2
  EXPECT_TRUE(std::isinf(r2(-0.038174, 0.061023, 0)));                             // never folds
  EXPECT_NEAR(r2(-2.0 / 3.0, 0.2, 0), 1.0, 1e-6);                                  // (1 - s)^2
  EXPECT_NEAR(r2(0, 0, -1.0 / 7.0), 1.0, 1e-12);                                   // 1 - s^3
  EXPECT_TRUE(std::isinf(r2(0, 0, 0)));
}

TEST(Camera, CheckNamesTheProblem) {
  Camera cam = DistortedCamera();
  cam.fx = -1;
  EXPECT_THROW(cam.Check(), std::invalid_argument);
  cam = DistortedCamera();
  cam.cam_from_world.rotation(0, 0) = 2;
  EXPECT_THROW(cam.Check(), std::invalid_argument);
}

TEST(Camera, ScaledCameraProjectsProportionally) {
  const Camera cam = DistortedCamera();
  const Camera half = ScaledCamera(cam, cam.width / 2, cam.height / 2);
  const Eigen::Vector3d X = cam.Center() + 4.0 * cam.PixelRayWorld({100.5, 200.5});
  EXPECT_NEAR((*half.Project(X) - *cam.Project(X) / 2).norm(), 0, 1e-9);
}

// Skew as published calibrations give it (Bouguet's and MATLAB's toolboxes, a
// decomposed 3x4 P): K = [fx s cx; 0 fy cy; 0 0 1] applied after distortion. The
// reference is the textbook formula, K times the homogeneous distorted point,
// written out here apart from Camera's arithmetic. Skew 0.08 fx (26 px) so that
// a camera that dropped it would be off by up to ~10 px in this view, not a
// fraction of one; tolerances: double rounding (1e-9 px) and Undistort's Newton
// iteration (1e-6 px, as the round trip above).
TEST(Camera, ASkewedCameraProjectsAndBackProjectsExactly) {
  for (const bool distorted : {false, true}) {
    Camera cam = DistortedCamera();
    if (!distorted) cam.distortion = {};
    cam.skew = 0.08 * cam.fx;
    cam.Check();
    const Eigen::Matrix3d K = cam.K();
    EXPECT_EQ(K(0, 1), cam.skew);
    double largest_shift = 0;
    for (double v = 0.05 * cam.height; v <= 0.95 * cam.height; v += 23.7)
      for (double u = 0.05 * cam.width; u <= 0.95 * cam.width; u += 21.3) {
        const Eigen::Vector2d uv(u, v);
        const Eigen::Vector3d X = cam.Center() + 2.9 * cam.PixelRayWorld(uv);
        const auto back = cam.Project(X);
        ASSERT_TRUE(back.has_value());
        EXPECT_NEAR((*back - uv).norm(), 0.0, 1e-6) << "pixel " << u << "," << v << " distorted " << distorted;
        // The reference: K (xd, yd, 1) with xd = Distort(x / z, y / z).
        const Eigen::Vector3d xc = cam.cam_from_world * X;
        const Eigen::Vector2d xd = cam.Distort({xc.x() / xc.z(), xc.y() / xc.z()});
        const Eigen::Vector3d h = K * Eigen::Vector3d(xd.x(), xd.y(), 1.0);
        EXPECT_NEAR((*back - h.head<2>() / h.z()).norm(), 0.0, 1e-9);
        EXPECT_NEAR((cam.ImagePlaneFromPixel(cam.PixelFromImagePlane(xd)) - xd).norm(), 0.0, 1e-15);
        Camera no_skew = cam;
        no_skew.skew = 0;
        largest_shift = std::max(largest_shift, (*no_skew.Project(X) - *back).norm());
      }
    EXPECT_GT(largest_shift, 5.0) << "the skew must matter in this test";
    // Scaled to half size, the skew halves with fx: projections halve exactly.
    const Camera half = ScaledCamera(cam, cam.width / 2, cam.height / 2);
    EXPECT_EQ(half.skew, cam.skew / 2);
    const Eigen::Vector3d X = cam.Center() + 4.0 * cam.PixelRayWorld({100.5, 200.5});
    EXPECT_NEAR((*half.Project(X) - *cam.Project(X) / 2).norm(), 0, 1e-9);
  }
  Camera bad = DistortedCamera();
  bad.skew = 1.01 * bad.fx;
  EXPECT_THROW(bad.Check(), std::invalid_argument);
  bad.skew = std::nan("");
  EXPECT_THROW(bad.Check(), std::invalid_argument);
}

}  // namespace
}  // namespace hullpipe
