// The exact ray–hull reference (image-based visual hull) against point queries,
// the plane sweep against the exact reference, depth refinement, and the hard
// cases, each with its exact expected result.
#include "hullpipe/reconstruction/exact_hull.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Geometry>

#include <gtest/gtest.h>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/evaluation/depth_eval.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/texture.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

TEST(Texture, VisibilityTestKeepsAnOccludedCamerasColourOff) {
  // A red sphere behind a blue one as camera A sees it; the eye, beside A, sees
  // the red sphere, which camera E also sees. With one camera blended (the best
  // aligned, A), the red sphere takes A's blue unless the visibility test rejects
  // A there (and E, next best, colours it).
  const Eigen::Vector3d C1(0, 0, -1), C2 = C1 + Eigen::Vector3d(0, -0.6, 0);
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Sphere(C1, 0.2));
  scene.shapes.back().colour = {40, 40, 220};
  scene.shapes.push_back(Shape::Sphere(C2, 0.2));
  scene.shapes.back().colour = {220, 60, 40};
  auto make = [](const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up) {
    Camera c;
    c.width = 240, c.height = 180;
    c.fx = c.fy = 240 / 2 / std::tan(0.3);
    c.cx = 120, c.cy = 90;
    c.cam_from_world = LookAt(eye, target, up).Inverse();
    return c;
  };
  const Eigen::Vector3d up(0, 0, -1);
  std::vector<Camera> cams = {make(C1 + Eigen::Vector3d(0, -3, 0), C1, up), make(C1 + Eigen::Vector3d(3, 0, 0), C1, up),
                              make(C1 + Eigen::Vector3d(0, 0, -3), C1, {1, 0, 0}),
                              make(C1 + Eigen::Vector3d(-2, 2, -1), C1, up),
                              // E: sees the red sphere's eye-facing side past the blue one,
                              // less aligned with the eye than A.
                              make(C1 + Eigen::Vector3d(2, -2, -2), C1, up)};
  std::vector<CameraMap> views;
  std::vector<CameraImage> images;
  for (auto& c : cams) {
    views.push_back({c, RenderExactMap(c, scene)});
    images.push_back({c, RenderColour(c, scene)});
  }
  const VolumeQuery q(views, test::BigBox());
  const NovelView view = NovelView::FromFov(160, 120, 0.5, LookAt(C1 + Eigen::Vector3d(1.6, -2.5, 0), C1, up));
  PlaneSweepOptions so;
  so.num_planes = 96;
  const cv::Rect all(0, 0, 160, 120);
  const cv::Mat depth = PlaneSweepCpu(q, view, SweepPlaneDepths(q, view, so), all, nullptr, 2, 8);
  Camera eye = make(view.world_from_eye.translation, C1, up);
  eye.width = 160, eye.height = 120, eye.fx = view.fx, eye.fy = view.fy, eye.cx = view.cx, eye.cy = view.cy;
  const cv::Mat truth = RenderColour(eye, scene);
  TextureOptions one;
  one.max_cameras = 1;
  const HullVisibility vis = ComputeHullVisibility(q, cams, 120, so, 8, 2);
  const cv::Mat plain = TextureHull(depth, all, view, images, one);
  const cv::Mat tested = TextureHull(depth, all, view, images, one, &vis);
  // On pixels whose true surface is the red sphere and where the hull lies on it
  // (within 1 cm; elsewhere the hull's phantom volume, not visibility, decides
  // which camera sees the point): how many come out blue?
  const cv::Mat true_depth = SceneDepth(scene, view);
  int red = 0, blue_plain = 0, blue_tested = 0;
  for (int r = 0; r < 120; ++r)
    for (int c = 0; c < 160; ++c) {
      const cv::Vec3b t = truth.at<cv::Vec3b>(r, c);
      if (!(t[2] > 2 * t[0] && t[2] > 60) || !std::isfinite(depth.at<float>(r, c))) continue;
      if (std::abs(depth.at<float>(r, c) - true_depth.at<float>(r, c)) > 0.01) continue;
      ++red;
      // Blue: the blue sphere's hue (B well above R), not the grey wall a
      // grazing camera may blend in at the red sphere's rim.
      auto blue = [](const cv::Vec3b& p) { return p[0] > 1.5 * p[2]; };
      blue_plain += blue(plain.at<cv::Vec3b>(r, c));
      blue_tested += blue(tested.at<cv::Vec3b>(r, c));
    }
  ASSERT_GT(red, 300);
  EXPECT_GT(blue_plain, red / 10) << "the case is hard: camera A sees blue there";
  EXPECT_LT(blue_tested, red / 50) << "the visibility test rejects A where the blue sphere hides the red one";
}

}  // namespace
}  // namespace hullpipe
