// ReprojectHullExact against the reference it shortcuts: RayHullIntervals
// (exact_hull.h, every camera over the whole ray, no tiles, no early exit) on
// every pixel, for the hull with and without the camera, on an undistorted
// synthetic rig with exact maps (the distorted reference is too slow for the
// suite: RayCameraSegments steps a quarter pixel there).
#include "hullpipe/evaluation/reprojection.h"

#include <gtest/gtest.h>

#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/reconstruction/exact_hull.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

cv::Mat Reference(const VolumeQuery& q, const Camera& camera) {
  cv::Mat out(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  for (int r = 0; r < camera.height; ++r)
    for (int c = 0; c < camera.width; ++c) {
      const Eigen::Vector3d d = camera.PixelRayWorld({c + 0.5, r + 0.5});
      if (!RayHullIntervals(q, camera.Center(), d, 0, 10.0).empty()) out.at<uint8_t>(r, c) = 255;
    }
  return out;
}

void Compare(const Distortion& distortion, double max_differing_fraction) {
  const SyntheticScene scene = NamedScene("hand", 0.3);
  const auto cams = DomeCameras(4, 2.0, Eigen::Vector3d(0, 0, -1.0), 96, 72, 1.0, distortion);
  std::vector<CameraMap> views;
  for (const auto& c : cams) views.push_back({c, RenderExactMap(c, scene)});
  Aabb ws;
  ws.min = Eigen::Vector3d(-2, -2, -2.5);
  ws.max = Eigen::Vector3d(2, 2, 0.05);
  const VolumeQuery all(views, ws);
  // One reprojector for every camera (its maps prepared once), on one thread
  // and on two.
  const ExactReprojector reprojector(all, 2);
  EXPECT_THROW(reprojector.Reproject(views.size()), std::out_of_range);
  EXPECT_THROW(reprojector.Reproject(0, 0), std::invalid_argument);
  for (size_t i = 0; i < views.size(); ++i) {
    SCOPED_TRACE("camera " + std::to_string(i + 1));
    std::vector<int> others;
    for (size_t j = 0; j < views.size(); ++j)
      if (j != i) others.push_back(int(j));
    const Reprojection got = reprojector.Reproject(i, 1 + int(i % 2));
    if (i == 0) {  // the one-camera call is the same reprojection
      const Reprojection once = ReprojectHullExact(all, i, 2);
      EXPECT_EQ(cv::countNonZero(once.all != got.all) + cv::countNonZero(once.leave_one_out != got.leave_one_out), 0);
    }
    const cv::Mat ref_loo = Reference(all.Subset(others), views[i].camera);
    const cv::Mat ref_all = Reference(all, views[i].camera);
    ASSERT_GT(cv::countNonZero(ref_loo), 20);  // the hand is in view
    const double n = double(views[i].camera.width * views[i].camera.height);
    EXPECT_LE(cv::countNonZero(got.leave_one_out != ref_loo) / n, max_differing_fraction);
    EXPECT_LE(cv::countNonZero(got.all != ref_all) / n, max_differing_fraction);
    // With itself, the hull reprojects inside the camera's own map.
    EXPECT_EQ(cv::countNonZero(got.all & ~views[i].map), 0);
  }
}

// Undistorted: the walk finds every pixel line its projection crosses in closed
// form, as the reference does, and cells are decided only where a whole cell is
// uniform, so not one pixel may differ.
TEST(ReprojectionExact, MatchesRayHullIntervalsPixelByPixel) { Compare({}, 0); }

// A rig like a published 20-camera dome (1024x768, k1 = -0.04, k2 = 0.06, one
// camera at the world's origin with the identity pose): a cell corner far
// outside a distorted camera's view projects to ~1e11 px, which once overflowed
// int on its way to a pixel index (SIGSEGV in the integral image). Every
// reprojection must run, and the hull reprojects inside the camera's own map.
TEST(ReprojectionExact, TwentyDistortedCamerasAtTheirRealSize) {
  const Eigen::Vector3d target(0, 0, 2.2);
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Sphere(target, 0.35));
  std::vector<Camera> cams = DomeCameras(20, 2.2, target, 1024, 768, 1.0, Distortion{-0.04, 0.06, 0, 0, 0});
  cams[7].cam_from_world = Rigid3d{};  // at the origin, looking along +z at the sphere
  std::vector<CameraMap> views;
  for (const auto& c : cams) views.push_back({c, RenderExactMap(c, scene)});
  ASSERT_GT(cv::countNonZero(views[7].map), 1000);  // the identity camera sees the sphere
  const VolumeQuery q(views, test::BigBox());
  const ExactReprojector reprojector(q, 1);
  // The identity camera's reprojection crashed (SIGSEGV) before the fix; the
  // others take minutes at this size (quarter-pixel steps in distorted views).
  const Reprojection got = reprojector.Reproject(7, 1);
  EXPECT_GT(cv::countNonZero(got.all), 1000);
  EXPECT_EQ(cv::countNonZero(got.all & ~views[7].map), 0);
}

}  // namespace
}  // namespace hullpipe
