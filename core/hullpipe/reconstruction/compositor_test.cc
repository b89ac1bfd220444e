// Composite's depth test and its pixel coverage (paper §3.3, §4: the nearest of
// hull, virtual objects and floor wins at each pixel).
#include "hullpipe/reconstruction/compositor.h"

#include <atomic>

#include <gtest/gtest.h>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/testing/stop_timing.h"

namespace hullpipe {
namespace {

// A view looking down +z from the origin (eye = world), 64 x 48, no hull.
struct Fixture {
  NovelView view = NovelView::FromFov(64, 48, 1.0, Rigid3d{});
  cv::Mat depth = cv::Mat(48, 64, CV_32FC1, cv::Scalar(kNoDepth));
  cv::Mat colour = cv::Mat(48, 64, CV_8UC3, cv::Scalar(0, 0, 0));
  CompositeOptions options;
  Fixture() { options.draw_floor = false; }
};

// A triangle covers exactly the pixels whose centres it holds, at its depth.
TEST(Composite, ATriangleCoversThePixelCentresItHolds) {
  Fixture f;
  VirtualMeshDraw m;
  m.vertices = {{-0.5, -0.5, 2}, {0.5, -0.5, 2}, {-0.5, 0.5, 2}};
  m.triangles = {{0, 1, 2}};
  cv::Mat depth;
  (void)Composite(f.view, f.depth, f.colour, {}, f.options, &depth, {&m});
  int covered = 0;
  for (int r = 0; r < 48; ++r)
    for (int c = 0; c < 64; ++c) {
      const Eigen::Vector3d ray = f.view.EyeRay(c + 0.5, r + 0.5);  // eye z 1
      const Eigen::Vector3d p = 2.0 * ray;                           // on the triangle's plane
      const bool inside = p.x() >= -0.5 && p.y() >= -0.5 && p.x() + p.y() <= 0.0;
      const float d = depth.at<float>(r, c);
      if (inside) {
        ++covered;
        EXPECT_NEAR(d, 2.0, 1e-5) << r << "," << c;
      } else {
        EXPECT_EQ(d, kNoDepth) << r << "," << c;
      }
    }
  EXPECT_GT(covered, 50);
}

// A box state is drawn from its state alone (VirtualObjectState SHAPE_BOX): a
// box turned 45 degrees about the view axis shows its near face as a diamond,
// |x| + |y| <= h sqrt(2) at its depth, red while it collides; nothing outside.
TEST(Composite, ABoxStateIsDrawnAtItsPoseAndRedWhileColliding) {
  Fixture f;
  VirtualObjectSample box;
  box.shape = VirtualObjectSample::Shape::kBox;
  box.position = Eigen::Vector3d(0, 0, 2);
  box.half_extents = Eigen::Vector3d(0.3, 0.3, 0.1);
  box.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitZ()));
  box.colliding = true;
  const VirtualMeshDraw d = BoxDraw(box, f.options.ball_colour);
  cv::Mat depth;
  const cv::Mat img = Composite(f.view, f.depth, f.colour, {}, f.options, &depth, {&d});
  const double reach = 0.3 * std::sqrt(2.0);
  int covered = 0;
  for (int r = 0; r < 48; ++r)
    for (int c = 0; c < 64; ++c) {
      const Eigen::Vector3d p = 1.9 * f.view.EyeRay(c + 0.5, r + 0.5);  // on the near face's plane
      const double l1 = std::abs(p.x()) + std::abs(p.y());
      if (std::abs(l1 - reach) < 0.01) continue;  // a pixel centre on the edge, either way
      const float dz = depth.at<float>(r, c);
      if (l1 < reach) {
        ++covered;
        EXPECT_NEAR(dz, 1.9, 1e-5) << r << "," << c;
        const cv::Vec3b px = img.at<cv::Vec3b>(r, c);  // red, flat-shaded
        EXPECT_TRUE(px[2] > 150 && px[2] > 3 * px[0] && px[2] > 3 * px[1]) << r << "," << c << ": " << px;
      } else {
        EXPECT_EQ(dz, kNoDepth) << r << "," << c;
      }
    }
  EXPECT_GT(covered, 100);
  box.colliding = false;  // control: the state's flag, not the geometry, makes it red
  const VirtualMeshDraw calm = BoxDraw(box, f.options.ball_colour);
  EXPECT_EQ(calm.colliding, std::vector<uint8_t>(12, 0));
  EXPECT_EQ(d.colliding, std::vector<uint8_t>(12, 1));
}

// Vertices and points whose projections lie ~1e13 px away (just in front of
// the eye, far to the side): pixel bounds clamp in floating point before they
// become ints (FloorPixel), so nothing overflows; what is in view is drawn.
TEST(Composite, FarProjectionsDoNotOverflowPixelIndices) {
  Fixture f;
  VirtualMeshDraw tri;
  tri.vertices = {{-0.5, -0.5, 2}, {1e12, -0.5, 0.06}, {-0.5, 1e12, 0.06}};
  tri.triangles = {{0, 1, 2}};
  VirtualMeshDraw points;
  points.vertices = {{1e12, 1e12, 0.06}, {-1e12, 0, 0.06}, {0, 0, 3}};
  points.point_radius = 1e9;  // discs of 1e13 px
  cv::Mat depth;
  (void)Composite(f.view, f.depth, f.colour, {}, f.options, &depth, {&tri, &points});
  EXPECT_GT(cv::countNonZero(depth < kNoDepth), 0);
  EXPECT_NO_THROW((void)Composite(f.view, f.depth, f.colour, {}, CompositeOptions{}, &depth, {}));
}

// A stop request ends a composite (polled per row, and every 1024 triangles
// while drawing meshes); without one the same call composites (positive
// control).
TEST(Composite, AStopRequestEndsItWithInterrupted) {
  Fixture f;
  VirtualMeshDraw m;
  m.vertices = {{-0.5, -0.5, 2}, {0.5, -0.5, 2}, {-0.5, 0.5, 2}};
  m.triangles = {{0, 1, 2}};
  std::atomic<bool> stop{true};
  EXPECT_THROW((void)Composite(f.view, f.depth, f.colour, {}, f.options, nullptr, {&m}, &stop), Interrupted);
  stop = false;
  EXPECT_NO_THROW((void)Composite(f.view, f.depth, f.colour, {}, f.options, nullptr, {&m}, &stop));
}

// A node stops within a second of SIGINT mid-composite (README, "Engineering
// rules"): a 4096x4096 view takes about 0.7 s here (8192x8192, render_node's
// largest, about 3 s); the flag is set 50 ms in and the composite must end
// within 0.5 s of it (a row is 4096 pixels, well under a millisecond).
TEST(Composite, AStopFlagEndsALargeCompositeWithinHalfASecond) {
  const int side = 4096;
  const NovelView view = NovelView::FromFov(side, side, 1.0, Rigid3d{});
  const cv::Mat depth(side, side, CV_32FC1, cv::Scalar(kNoDepth));
  const cv::Mat colour(side, side, CV_8UC3, cv::Scalar(0, 0, 0));
  const auto t = test::StopAfter(std::chrono::milliseconds(50), [&](StopFlag stop) {
    (void)Composite(view, depth, colour, {{Eigen::Vector3d(0, 0, 3), 0.5, false}}, {}, nullptr, {}, stop);
  });
  ASSERT_TRUE(t.seconds) << "the composite finished before the flag was set; it proves nothing";
  EXPECT_LT(*t.seconds, 0.5 * test::TimeScale());
  EXPECT_NE(t.what.find("composite"), std::string::npos) << t.what;
}

}  // namespace
}  // namespace hullpipe
