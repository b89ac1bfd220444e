#include "hullpipe/capture/live_pose_track.h"

#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace hullpipe {
namespace {

Rigid3d Pose(double angle_z, double x) {
  Rigid3d p;
  p.rotation = Eigen::AngleAxisd(angle_z, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  p.translation = Eigen::Vector3d(x, 0, -1);
  return p;
}

constexpr int64_t kMs = 1'000'000;

// Between two samples: the position linearly, the rotation by slerp (exact for
// a turn about one axis: the angle interpolates linearly).
TEST(LivePoseTrack, InterpolatesBetweenSamplesAndHoldsNearTheEnds) {
  LivePoseTrack track(0.05);
  ASSERT_EQ(track.Add(1000 * kMs, Pose(0.0, 0.0)), "");
  ASSERT_EQ(track.Add(1010 * kMs, Pose(0.4, 1.0)), "");
  const auto mid = track.At(1002 * kMs + kMs / 2);  // a quarter of the way
  ASSERT_TRUE(mid);
  EXPECT_NEAR(mid->translation.x(), 0.25, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(mid->rotation).angle(), 0.1, 1e-12);
  // Past the newest by at most max_hold: the newest; further: none.
  ASSERT_TRUE(track.At(1060 * kMs));
  EXPECT_NEAR(track.At(1060 * kMs)->translation.x(), 1.0, 1e-15);
  EXPECT_FALSE(track.At(1060 * kMs + 1));
  EXPECT_TRUE(track.At(950 * kMs));
  EXPECT_FALSE(track.At(950 * kMs - 1));
  EXPECT_NEAR(track.DistanceS(1100 * kMs), 0.09, 1e-12);
}

// A gap wider than 2 max_hold is not interpolated across: its ends hold near
// them, the middle has no pose.
TEST(LivePoseTrack, AGapInTheTrackerIsNotBridged) {
  LivePoseTrack track(0.05);
  ASSERT_EQ(track.Add(0, Pose(0, 0)), "");
  ASSERT_EQ(track.Add(500 * kMs, Pose(0, 5)), "");
  EXPECT_NEAR(track.At(40 * kMs)->translation.x(), 0, 0);
  EXPECT_NEAR(track.At(460 * kMs)->translation.x(), 5, 0);
  EXPECT_FALSE(track.At(250 * kMs));
}

TEST(LivePoseTrack, RefusesSamplesOutOfOrderOrNotPosesAndIsBounded) {
  LivePoseTrack track(0.05);
  ASSERT_EQ(track.Add(10, Pose(0, 0)), "");
  EXPECT_NE(track.Add(10, Pose(0, 1)).find("not after"), std::string::npos);
  Rigid3d bad = Pose(0, 0);
  bad.rotation(0, 0) = 2;
  EXPECT_NE(track.Add(20, bad).find("rotation"), std::string::npos);
  bad = Pose(0, 0);
  bad.translation.x() = std::nan("");
  EXPECT_NE(track.Add(20, bad).find("translation"), std::string::npos);
  for (int64_t i = 1; i <= 1000; ++i) ASSERT_EQ(track.Add(10 + i * kMs, Pose(0, double(i))), "");
  EXPECT_EQ(track.size(), LivePoseTrack::kMaxSamples);
  EXPECT_THROW(LivePoseTrack(0), std::invalid_argument);
}

}  // namespace
}  // namespace hullpipe
