// Head-pose logs (the tracked viewpoint, paper §3): poses interpolated between
// samples, bad files refused naming the file.
#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <fstream>

#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/scenes/ball.h"
#include "hullpipe/scenes/cloth.h"
#include "hullpipe/geometry/head_pose.h"
#include "hullpipe/scenes/particles.h"
#include "hullpipe/geometry/rigid3.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/scenes/virtual_scene.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

TEST(HeadPose, FileTrackInterpolatesAndRejectsBadFiles) {
  const auto dir = test::TempDir("pose");
  const std::string path = (dir / "poses.csv").string();
  {
    std::ofstream f(path);
    // A quarter turn about world z between t = 0 and t = 2, moving 1 m along x.
    f << "t,x,y,z,qw,qx,qy,qz\n0,0,0,-1,1,0,0,0\n2,1,0,-1," << std::cos(M_PI / 4) << ",0,0," << std::sin(M_PI / 4)
      << "\n";
  }
  const PoseTrack track = LoadPoseTrack(path);
  ASSERT_EQ(track.size(), 2u);
  const Rigid3d mid = track.At(1.0);
  EXPECT_TRUE(mid.translation.isApprox(Eigen::Vector3d(0.5, 0, -1), 1e-12));
  EXPECT_TRUE(mid.rotation.isApprox(Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitZ()).toRotationMatrix(), 1e-9));
  EXPECT_TRUE(track.At(-5).translation.isApprox(Eigen::Vector3d(0, 0, -1)));  // held at the ends
  EXPECT_TRUE(track.At(9).translation.isApprox(Eigen::Vector3d(1, 0, -1)));
  auto bad = [&](const std::string& body) {
    std::ofstream(path) << body;
    return [&] { LoadPoseTrack(path); };
  };
  EXPECT_THROW(bad("t,x\n0,1,2\n")(), std::runtime_error);                  // columns
  EXPECT_THROW(bad("0,0,0,0,0,0,0,0\n")(), std::runtime_error);             // zero quaternion
  EXPECT_THROW(bad("0,0,0,0,1,0,0,0\n0,1,0,0,1,0,0,0\n")(), std::runtime_error);  // same time
  EXPECT_THROW(bad("0,0,0,0,1,0,0,0\n1,a,0,0,1,0,0,0\n")(), std::runtime_error);  // not a number
  EXPECT_THROW(LoadPoseTrack((dir / "missing.csv").string()), std::runtime_error);
}

}  // namespace
}  // namespace hullpipe
