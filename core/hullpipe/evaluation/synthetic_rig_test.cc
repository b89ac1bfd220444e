// The rig written to disk for "another rig" (docs/rigs.md): its calibration, read
// back by the importer, is the cameras written, in a z-up world where the figure
// stands on the floor; and its images show the figure exactly where that
// calibration says it is.
#include "hullpipe/evaluation/synthetic_rig.h"

#include <filesystem>
#include <functional>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/geometry/calibration.h"
#include "hullpipe/geometry/rig_import.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

SyntheticRigFilesOptions Small(const std::string& format) {
  SyntheticRigFilesOptions o;
  o.cameras = 4;
  o.width = 160;
  o.height = 120;
  o.frames = 3;
  o.background_frames = 2;
  o.noise_sigma = 0;  // the first frame's PNG is then the rendering itself
  o.format = format;
  return o;
}

void ExpectSameCamera(const Camera& a, const Camera& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  for (const auto& [x, y] : {std::pair{a.fx, b.fx}, {a.fy, b.fy}, {a.cx, b.cx}, {a.cy, b.cy}, {a.skew, b.skew}})
    EXPECT_NEAR(x, y, 1e-9);
  for (int k = 0; k < 5; ++k) EXPECT_NEAR(a.distortion[size_t(k)], b.distortion[size_t(k)], 1e-12);
  EXPECT_LT((a.cam_from_world.rotation - b.cam_from_world.rotation).norm(), 1e-9);
  EXPECT_LT((a.cam_from_world.translation - b.cam_from_world.translation).norm(), 1e-9);
}

// The figure moved into the written world by the test's own transform of its
// shapes (spheres and capsules: their points; no rotation matters for them).
SyntheticScene FigureInWorld(const Rigid3d& world_from_figure) {
  SyntheticScene s = AnimatedFigure(0);
  for (Shape& sh : s.shapes) {
    sh.a = world_from_figure * sh.a;
    sh.b = world_from_figure * sh.b;
    sh.rotation = world_from_figure.rotation * sh.rotation;
  }
  return s;
}

// Object pixels of a noiseless frame: where it differs from the empty scene.
cv::Mat ObjectPixels(const cv::Mat& frame, const cv::Mat& empty) {
  cv::Mat diff, grey;
  cv::absdiff(frame, empty, diff);
  cv::cvtColor(diff, grey, cv::COLOR_BGR2GRAY);
  return grey > 0;
}

TEST(SyntheticRigFiles, TheWorldIsZUpWithTheFigureStandingOnItsFloor) {
  const Rigid3d w = SyntheticRigWorldFromFigure();
  // The figure's up (its frame's -z) is the world's +z; its feet stay on z = 0;
  // its head (1.58 m up its axis) is 1.58 m above (1.5, -0.8).
  EXPECT_LT((w.rotation * Eigen::Vector3d(0, 0, -1) - Eigen::Vector3d(0, 0, 1)).norm(), 1e-15);
  EXPECT_LT((w * Eigen::Vector3d(0, 0, -1.58) - Eigen::Vector3d(1.5, -0.8, 1.58)).norm(), 1e-15);
  EXPECT_NEAR(w.rotation.determinant(), 1.0, 1e-15);
  EXPECT_NEAR((w * Eigen::Vector3d(1, 0, 0)).z(), 0, 1e-15);  // the floor stays the floor
}

TEST(SyntheticRigFiles, ColmapModelImportsToTheCamerasThatFilmedTheFigure) {
  const auto dir = test::TempDir("synthetic_rig_colmap");
  const SyntheticRigFiles f = WriteSyntheticRigFiles(Small("colmap"), dir.string());
  ASSERT_EQ(f.cameras.size(), 4u);
  const Rig rig = ImportColmap((dir / "sparse" / "0").string());
  ASSERT_EQ(rig.cameras.size(), 4u);
  const SyntheticScene world_figure = FigureInWorld(f.world_from_figure);
  const SyntheticScene figure_at_origin = AnimatedFigure(0);  // positive control: not moved
  for (size_t i = 0; i < 4; ++i) {
    SCOPED_TRACE("camera " + std::to_string(i + 1));
    const Camera& cam = rig.cameras[i].camera;
    ExpectSameCamera(cam, f.cameras[i]);
    // The image the model names is the first frame, noiseless, lossless.
    const cv::Mat frame = cv::imread((dir / "images" / ("cam" + std::to_string(cam.id) + ".png")).string());
    ASSERT_FALSE(frame.empty());
    ASSERT_EQ(frame.size(), cv::Size(160, 120));
    Camera in_figure_frame = cam;
    in_figure_frame.cam_from_world = cam.cam_from_world * f.world_from_figure;
    const cv::Mat seen = ObjectPixels(frame, RenderColour(in_figure_frame, SyntheticScene{}));
    const int n = cv::countNonZero(seen);
    ASSERT_GT(n, 200) << "the figure should fill part of the view";
    // Where the imported calibration says the figure is (the exact map of the
    // figure placed in the z-up world by the test): the same pixels, but for
    // pixel centres whose ray grazes a shape within rounding (none expected;
    // 2 allowed).
    cv::Mat diff;
    cv::bitwise_xor(seen, RenderExactMap(cam, world_figure), diff);
    EXPECT_LE(cv::countNonZero(diff), 2);
    cv::bitwise_xor(seen, RenderExactMap(cam, figure_at_origin), diff);
    EXPECT_GT(cv::countNonZero(diff), n / 2) << "positive control: the figure at the world origin is elsewhere";
  }
}

TEST(SyntheticRigFiles, RigFileDerivesAZUpWorldAndNamesVideosThatPlay) {
  const auto dir = test::TempDir("synthetic_rig_yaml");
  const SyntheticRigFiles f = WriteSyntheticRigFiles(Small("yaml"), dir.string());
  const Rig rig = LoadRig((dir / "rig.yaml").string());
  ASSERT_EQ(rig.cameras.size(), 4u);
  EXPECT_EQ(rig.world.up, Eigen::Vector3d(0, 0, 1));  // derived from the cameras' image-up
  EXPECT_EQ(rig.world.floor, RigWorld::Floor::kUnderHull);
  for (size_t i = 0; i < 4; ++i) {
    ExpectSameCamera(rig.cameras[i].camera, f.cameras[i]);
    for (const auto& [path, frames] : {std::pair{rig.cameras[i].frames, 3}, {rig.cameras[i].background, 2}}) {
      cv::VideoCapture v(path);
      ASSERT_TRUE(v.isOpened()) << path;
      int count = 0;
      for (cv::Mat m; v.read(m); ++count) ASSERT_EQ(m.size(), cv::Size(160, 120)) << path;
      EXPECT_EQ(count, frames) << path;
    }
  }
}

// A skewed rig (as MATLAB's toolbox calibrates one) is written with its skew,
// which the rig file keeps; the videos are filmed through the skewed K
// (RenderColour follows Camera::PixelRayWorld).
TEST(SyntheticRigFiles, ASkewedRigIsFilmedAndWrittenWithItsSkew) {
  const auto dir = test::TempDir("synthetic_rig_skew");
  SyntheticRigFilesOptions o = Small("yaml");
  o.skew = 12;
  const SyntheticRigFiles f = WriteSyntheticRigFiles(o, dir.string());
  const Rig rig = LoadRig((dir / "rig.yaml").string());
  ASSERT_EQ(rig.cameras.size(), 4u);
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(rig.cameras[i].camera.skew, 12.0);
    ExpectSameCamera(rig.cameras[i].camera, f.cameras[i]);
  }
}

TEST(SyntheticRigFiles, OptionsCheckNamesTheField) {
  for (const auto& [set, field] : std::vector<std::pair<std::function<void(SyntheticRigFilesOptions&)>, std::string>>{
           {[](auto& o) { o.cameras = 2; }, "cameras"},
           {[](auto& o) { o.width = 8; }, "side"},
           {[](auto& o) { o.fps = 0; }, "fps"},
           {[](auto& o) { o.noise_sigma = -1; }, "noise"},
           {[](auto& o) { o.format = "nerf"; }, "format"},
           {[](auto& o) { o.skew = 5; }, "skew needs format yaml"},
           {[](auto& o) { o.format = "yaml", o.skew = 1e9; }, "skew must be"}}) {
    SyntheticRigFilesOptions o;
    set(o);
    try {
      o.Check();
      ADD_FAILURE() << field;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace hullpipe
