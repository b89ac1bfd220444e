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
