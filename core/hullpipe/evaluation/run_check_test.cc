// A run's composited depth against the direct sweep and the exact intervals
// (run_check.h): exact ground truth on a sphere seen by four cameras with
// exact maps; each comparison has a control that a wrong depth or a wrong
// sampling fails.
#include "hullpipe/evaluation/run_check.h"

#include <fstream>

#include <gtest/gtest.h>

#include "hullpipe/reconstruction/exact_hull.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

VolumeQuery SphereQuery() {
  return VolumeQuery(test::SphereViews(4, 160, 120, test::kSphereCentre, test::kSphereRadius), test::BigBox());
}

TEST(RunCheck, TheDirectSweepIsEqualEverywhereAndWithinTheSweepsSamplingOfTheExactHull) {
  const VolumeQuery q = SphereQuery();
  const NovelView view = test::SphereSideView(96, 72);
  RunCheckOptions o;
  const cv::Mat sweep = PlaneSweepCpu(q, view, SweepPlaneDepths(q, view, o.sweep),
                                      cv::Rect(0, 0, view.width, view.height), nullptr, 1, o.refine);
  const RunFrameCheck c = CheckRunFrame(q, view, sweep, o);
  EXPECT_EQ(c.pixels, 96 * 72);
  EXPECT_EQ(c.equal_to_sweep, c.pixels);
  EXPECT_GT(c.hull_pixels, 500) << "the sphere is in view";
  EXPECT_EQ(c.exact_pixels, c.pixels);
  // 50 planes and 6 bisections put a depth within spacing / 64 (~1 mm here) of
  // the exact first hit; a ray grazing the silhouette between two planes may
  // be missed (a few pixels), never hull where there is none.
  EXPECT_LT(c.exact.err_mm_median, 1.0);
  EXPECT_EQ(c.exact.only_got, 0);
  EXPECT_LT(c.exact.only_ref, c.hull_pixels / 50);

  // Control: the same depth 5 mm behind is equal nowhere on the hull and 5 mm off.
  cv::Mat behind = sweep.clone();
  behind += 0.005;
  const RunFrameCheck d = CheckRunFrame(q, view, behind, o);
  EXPECT_EQ(d.equal_to_sweep, d.pixels - d.hull_pixels);
  EXPECT_NEAR(d.exact.signed_mm_median, 5.0, 1.0);
}

TEST(RunCheck, TheStridesPixelsAreTheRunsOwnRays) {
  // The exact hull fed as the run's depth: on the stride's pixels it must match
  // the reference to rounding, which holds only if the sampled view's pixel
  // (r, k) has the centre of the run's pixel (3r, 3k). The view is off-centre
  // (cx, cy not the image's middle) so a mapping that ignored the +0.5 or the
  // principal point would be off by a pixel along the silhouette.
  const VolumeQuery q = SphereQuery();
  NovelView view = test::SphereSideView(100, 70);
  view.cx = 41.3, view.cy = 37.9;
  const cv::Mat exact = ExactHullDepth(q, view, cv::Rect(0, 0, view.width, view.height));
  RunCheckOptions o;
  o.exact_stride = 3;
  const RunFrameCheck c = CheckRunFrame(q, view, exact, o);
  EXPECT_EQ(c.exact_pixels, 34 * 24);  // ceil(100 / 3) x ceil(70 / 3)
  EXPECT_GT(c.exact.both, 50);
  EXPECT_EQ(c.exact.only_got, 0);
  EXPECT_EQ(c.exact.only_ref, 0);
  EXPECT_LT(c.exact.err_mm_max, 1e-6);
  // Control: shifted by one pixel, the silhouette's pixels disagree.
  cv::Mat shifted = cv::Mat(exact.size(), CV_32FC1, cv::Scalar(kNoDepth));
  exact(cv::Rect(1, 0, exact.cols - 1, exact.rows)).copyTo(shifted(cv::Rect(0, 0, exact.cols - 1, exact.rows)));
  const RunFrameCheck s = CheckRunFrame(q, view, shifted, o);
  EXPECT_GT(s.exact.only_got + s.exact.only_ref, 0);
  EXPECT_THROW(CheckRunFrame(q, view, exact(cv::Rect(0, 0, 50, 70)), o), std::invalid_argument);
  o.exact_stride = 0;
  EXPECT_THROW(CheckRunFrame(q, view, exact, o), std::invalid_argument);
}

TEST(RunCheck, ViewsCsvReadsAsRenderWritesItAndBadRowsAreNamed) {
  const auto dir = test::TempDir("run_check_views");
  const std::string header =
      "frame_seq,path_time_s,width,height,fx,fy,cx,cy,r00,r01,r02,r10,r11,r12,r20,r21,r22,tx,ty,tz\n";
  const std::string row = "7,0.25,160,120,150,151,80.5,60,1,0,0,0,1,0,0,0,1,0.5,-1,2\n";
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream((dir / name).string()) << text;
    return (dir / name).string();
  };
  const auto rows = ReadRunViews(write("good.csv", header + row));
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].frame_seq, 7u);
  EXPECT_EQ(rows[0].view.width, 160);
  EXPECT_EQ(rows[0].view.fy, 151);
  EXPECT_EQ(rows[0].view.cx, 80.5);
  EXPECT_EQ(rows[0].view.world_from_eye.translation, Eigen::Vector3d(0.5, -1, 2));
  EXPECT_EQ(RunDepthPath("/r", 7), "/r/frame_00007_depth.tiff");
  auto message = [&](const std::string& name, const std::string& text) {
    const std::string path = write(name, text);
    try {
      ReadRunViews(path);
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      return std::string(e.what());
    }
    ADD_FAILURE() << name << " was accepted";
    return std::string();
  };
  EXPECT_NE(message("header.csv", "a,b\n" + row).find("line 1"), std::string::npos);
  EXPECT_NE(message("short.csv", header + "7,0.25,160\n").find("line 2: 3 fields"), std::string::npos);
  EXPECT_NE(message("word.csv", header + row + "x" + row).find("line 3"), std::string::npos);
  EXPECT_NE(message("nan.csv", header + "7,nan,160,120,150,151,80.5,60,1,0,0,0,1,0,0,0,1,0.5,-1,2\n")
                .find("not a finite number"),
            std::string::npos);
  EXPECT_NE(message("rot.csv", header + "7,0.25,160,120,150,151,80.5,60,2,0,0,0,1,0,0,0,1,0.5,-1,2\n")
                .find("not a rotation"),
            std::string::npos);
  EXPECT_NE(message("seq.csv", header + "0,0.25,160,120,150,151,80.5,60,1,0,0,0,1,0,0,0,1,0.5,-1,2\n")
                .find("frame_seq"),
            std::string::npos);
  EXPECT_NE(message("size.csv", header + "7,0.25,0,120,150,151,80.5,60,1,0,0,0,1,0,0,0,1,0.5,-1,2\n")
                .find("width"),
            std::string::npos);
  EXPECT_THROW(ReadRunViews((dir / "missing.csv").string()), std::runtime_error);
}

}  // namespace
}  // namespace hullpipe
