#include "hullpipe/geometry/camera.h"

#include <cmath>

#include <gtest/gtest.h>

#include "hullpipe/geometry/calibration.h"
#include "hullpipe/evaluation/synthetic.h"

namespace hullpipe {
namespace {

TEST(Rigid3, InverseAndLookAt) {
  const Rigid3d pose = LookAt({1, 2, -3}, {0, 0, -1}, {0, 0, -1});
  EXPECT_NEAR((pose.rotation.transpose() * pose.rotation - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
  EXPECT_NEAR(pose.rotation.determinant(), 1.0, 1e-12);
  const Rigid3d id = pose * pose.Inverse();
  EXPECT_NEAR((id.rotation - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
  // Camera y (down in the image) points along world +z (down in this rig).
  EXPECT_GT(pose.rotation.col(1).z(), 0);
}

}  // namespace
}  // namespace hullpipe

namespace hullpipe {
namespace {

// A rotation passes; a reflection, a scaled matrix, one off by more than the
// tolerance and one with a NaN do not.
TEST(IsRotation, AcceptsRotationsOnly) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  EXPECT_TRUE(IsRotation(r));
  EXPECT_FALSE(IsRotation(-r)) << "a reflection (det -1)";
  EXPECT_FALSE(IsRotation(1.001 * r));
  Eigen::Matrix3d off = r;
  off(0, 1) += 2e-6;
  EXPECT_FALSE(IsRotation(off));
  off(0, 1) = r(0, 1) + 2e-7;
  EXPECT_TRUE(IsRotation(off));
  Eigen::Matrix3d nan = r;
  nan(2, 2) = std::nan("");
  EXPECT_FALSE(IsRotation(nan));
}

}  // namespace
}  // namespace hullpipe
