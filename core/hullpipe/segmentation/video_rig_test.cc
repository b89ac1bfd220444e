// The segmented rig of files: the generic YAML rig with ready-made masks or image
// sequences, camera subsets, tracked cameras.
#include "hullpipe/segmentation/video_rig.h"

#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "hullpipe/geometry/calibration.h"
#include "hullpipe/evaluation/reprojection.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/texture.h"
#include "hullpipe/reconstruction/volume_query.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

// Writes a 2-camera rig of image sequences (frames + masks) of the animated figure.
std::string WriteImageRig(const std::filesystem::path& dir, bool with_masks, int frames) {
  Rig rig;
  const auto cams = RingCameras(2, 4.0, 2.0, Eigen::Vector3d(0, 0, -0.9), 96, 72, 1.0);
  for (const auto& c : cams) {
    const std::string cd = "cam" + std::to_string(c.id);
    std::filesystem::create_directories(dir / cd);
    cv::imwrite((dir / cd / "background.png").string(), RenderColour(c, SyntheticScene{}));
    for (int k = 0; k < frames; ++k) {
      const SyntheticScene s = AnimatedFigure(k * 0.2);
      cv::imwrite((dir / cd / cv::format("frame_%03d.png", k)).string(), RenderColour(c, s));
      cv::imwrite((dir / cd / cv::format("mask_%03d.png", k)).string(), RenderExactMap(c, s));
    }
    rig.cameras.push_back(
        {c, cd + "/background.png", cd + "/frame_%03d.png", with_masks ? cd + "/mask_%03d.png" : "", 0.0, ""});
  }
  WriteRigYaml(rig, (dir / "rig.yaml").string());
  return (dir / "rig.yaml").string();
}

TEST(RigSource, YamlRigWithReadyMadeMasks) {
  const auto dir = test::TempDir("rig_masks");
  const auto rig = OpenVideoRig(WriteImageRig(dir, true, 3), {});
  ASSERT_EQ(rig->cameras().size(), 2u);
  RigFrame f;
  int n = 0;
  while (rig->Next(&f)) {
    for (size_t i = 0; i < 2; ++i) {
      const cv::Mat truth = RenderExactMap(rig->cameras()[i], AnimatedFigure(n * 0.2));
      EXPECT_EQ(cv::countNonZero(f.maps[i] != truth), 0) << "frame " << n;  // masks used as given
    }
    ++n;
  }
  EXPECT_EQ(n, 3);
}

TEST(RigSource, YamlRigOfImageSequencesIsSegmented) {
  const auto dir = test::TempDir("rig_images");
  const auto rig = OpenVideoRig(WriteImageRig(dir, false, 2), {});
  RigFrame f;
  ASSERT_TRUE(rig->Next(&f));
  const cv::Mat truth = RenderExactMap(rig->cameras()[0], AnimatedFigure(0));
  EXPECT_GE(MaskIoU(f.maps[0], truth), 0.9);  // small 96x72 images: borders weigh more
}

// A rig whose camera names its frames by the first file reads the whole
// sequence as the pattern does; when one of its files is bad, the rig does not
// open and the line names that file (it once read one frame, then ended the run
// with "camera(s) 1 ended after frame 1" and no reason).
TEST(RigSource, FramesNamedByTheirFirstFileAreTheSequence) {
  const auto dir = test::TempDir("rig_first_file");
  const std::string path = WriteImageRig(dir, false, 3);
  Rig rig = LoadRig(path);
  rig.cameras[0].frames = "cam1/frame_000.png";
  WriteRigYaml(rig, (dir / "first.yaml").string());
  {
    const auto source = OpenVideoRig((dir / "first.yaml").string(), {});
    RigFrame f;
    int n = 0;
    while (source->Next(&f)) ++n;
    EXPECT_EQ(n, 3);
    EXPECT_EQ(source->IncompleteEnd(), "");
  }
  std::ofstream(dir / "cam1" / "frame_002.png", std::ios::binary) << "text, not a PNG";
  try {
    const auto source = OpenVideoRig((dir / "first.yaml").string(), {});
    RigFrame f;
    while (source->Next(&f)) {
    }
    ADD_FAILURE() << "a bad file was read past: " << source->IncompleteEnd();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("frame_002.png"), std::string::npos) << e.what();
  }
}

// The backgrounds are learnt from the cameras' files at once: each camera's
// object-pixel map is the one the camera gives when opened alone (one thread).
TEST(RigSource, BackgroundsLearntTogetherEqualEachLearntAlone) {
  const auto dir = test::TempDir("rig_backgrounds");
  const std::string path = WriteImageRig(dir, false, 1);
  RigFrame all;
  ASSERT_TRUE(OpenVideoRig(path, {})->Next(&all));
  for (const int id : {1, 2}) {
    VideoRigOptions o;
    o.camera_ids = {id};
    RigFrame one;
    ASSERT_TRUE(OpenVideoRig(path, o)->Next(&one));
    EXPECT_EQ(cv::countNonZero(one.maps[0] != all.maps[size_t(id - 1)]), 0) << "camera " << id;
  }
}

// Every camera's frames open before any background is learnt (learning takes
// seconds a camera): with camera 2's frames gone and camera 1's background
// broken, the line names camera 2's frames. With both backgrounds broken, it
// names camera 1's, whichever thread failed first.
TEST(RigSource, AMissingVideoIsNamedBeforeAnyBackgroundIsRead) {
  const auto dir = test::TempDir("rig_open_first");
  const std::string path = WriteImageRig(dir, false, 2);
  for (const char* cam : {"cam1", "cam2"})
    std::ofstream(dir / cam / "background.png", std::ios::binary) << "text, not a PNG";
  try {
    OpenVideoRig(path, {});
    ADD_FAILURE() << "opened with broken backgrounds";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("camera 1: background"), std::string::npos) << e.what();
  }
  for (int k = 0; k < 2; ++k) std::filesystem::remove(dir / "cam2" / cv::format("frame_%03d.png", k));
  try {
    OpenVideoRig(path, {});
    ADD_FAILURE() << "opened without camera 2's frames";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("camera 2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("frame_%03d.png"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find("background"), std::string::npos) << e.what();
  }
}

TEST(RigSource, CameraSubsetKeepsTheRigSize) {
  const auto dir = test::TempDir("rig_subset");
  VideoRigOptions o;
  o.camera_ids = {2};
  const auto rig = OpenVideoRig(WriteImageRig(dir, true, 1), o);
  ASSERT_EQ(rig->cameras().size(), 1u);
  EXPECT_EQ(rig->cameras()[0].id, 2);
  EXPECT_EQ(rig->rig_camera_count(), 2);  // a complete frameset still needs both
  o.camera_ids = {7};
  EXPECT_THROW(OpenVideoRig((dir / "rig.yaml").string(), o), std::runtime_error);
}

TEST(RigSource, ATrackedCameraOfAFileRigTakesItsPoseFromItsLog) {
  const auto dir = test::TempDir("rig_tracked");
  const std::string path = WriteImageRig(dir, true, 3);
  Rig rig = LoadRig(path);
  // world_from_camera: 1 m along x at t = 0, 3 m at t = 1 s (linear in between).
  std::ofstream(dir / "poses.csv") << "t,x,y,z,qw,qx,qy,qz\n0,1,0,-1,1,0,0,0\n1,3,0,-1,1,0,0,0\n";
  rig.cameras[1].tracked = "poses.csv";
  WriteRigYaml(rig, (dir / "tracked.yaml").string());
  const auto source = OpenVideoRig((dir / "tracked.yaml").string(), {});
  RigFrame f;
  ASSERT_TRUE(source->Next(&f));
  ASSERT_TRUE(source->Next(&f));  // frame 1: source time 1 / fps
  ASSERT_EQ(f.poses.size(), 2u);
  EXPECT_FALSE(f.poses[0].has_value());  // a fixed camera
  ASSERT_TRUE(f.poses[1].has_value());
  const double x = 1 + 2 * f.time_s;
  EXPECT_NEAR((f.poses[1]->Inverse().translation - Eigen::Vector3d(x, 0, -1)).norm(), 0, 1e-12);
  // A live camera with a pose log is refused, naming the key.
  rig.cameras[1].frames = "udp://127.0.0.1:5999";
  rig.cameras[1].masks.clear();  // (a live camera has none)
  WriteRigYaml(rig, (dir / "live_tracked.yaml").string());
  try {
    OpenVideoRig((dir / "live_tracked.yaml").string(), {});
    ADD_FAILURE() << "a live tracked camera was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("'tracked'"), std::string::npos) << "got: " << e.what();
  }
}

// A published dome (20 cameras, 1024x768, skewed and distorted; its world is
// camera 1's): the hull box of its frame is the hull's own, within two of the
// search's leaves, and holds every inside point of a 2-cm grid of the
// workspace. Before the cell rule counted only the cameras that may see an
// inside point, and ruled out cells outside a camera's view whose corners it
// cannot project (below the dome, beyond the lens's valid radius), the box was
// the whole workspace (1.0 x 2.0 x 1.5 m for a 0.8 x 1.6 x 1.0 m hull), and
// every sweep through it cost 10x.
TEST(RigSource, APublishedDomesHullBoxIsItsHulls) {
  const std::string rig = std::string(HULLPIPE_DOME_DIR) + "/rig.yaml";
  if (!std::ifstream(rig)) GTEST_SKIP() << rig << " not found (../shared beside the clone)";
  auto src = OpenVideoRig(rig, {});
  RigFrame f;
  ASSERT_TRUE(src->Next(&f));
  std::vector<CameraMap> views;
  for (size_t i = 0; i < src->cameras().size(); ++i) views.push_back({src->cameras()[i], f.maps[i]});
  ASSERT_EQ(views.size(), 20u);
  const Aabb ws = src->workspace();
  const VolumeQuery q(views, ws);
  const Aabb& box = q.hull_box();
  const double step = 0.02;
  Aabb sampled;
  for (double x = ws.min.x() + step / 2; x < ws.max.x(); x += step)
    for (double y = ws.min.y() + step / 2; y < ws.max.y(); y += step)
      for (double z = ws.min.z() + step / 2; z < ws.max.z(); z += step) {
        const Eigen::Vector3d p(x, y, z);
        if (!q.Inside(p)) continue;
        sampled.Extend(p);
        ASSERT_TRUE(box.Contains(p)) << p.transpose() << " is inside the hull but not in its box";
      }
  ASSERT_FALSE(sampled.empty());
  // The search's leaf: the start box's largest side / 64 within [5 mm, 2 cm].
  const double slack = 2 * 0.02 + step;
  EXPECT_LT((sampled.min - box.min).maxCoeff(), slack) << box.min.transpose() << " vs " << sampled.min.transpose();
  EXPECT_LT((box.max - sampled.max).maxCoeff(), slack) << box.max.transpose() << " vs " << sampled.max.transpose();
}

// Real rigs' maps (segmented, not exact; skewed and distorted lenses): the
// CPU sweep skipping the frameset's empty space (EmptySpace) returns bit for
// bit what the sweep asking every camera returns, refined as recon refines, in
// a view from outside the hull box and in one from inside it.
TEST(RigSource, RealRigsSweepTheSameSkippingEmptySpace) {
  for (const std::string& rig : test::RealRigs()) {
    const test::RealRigFrame first = test::FirstFrameOf(rig);
    if (!first.source) GTEST_SKIP() << rig << " not found (../shared beside the clone)";
    const auto& [src, f, views] = first;
    VolumeQueryOptions without_grid;
    without_grid.empty_space_cells = 0;
    const VolumeQuery with(views, src->workspace()), without(views, src->workspace(), without_grid);
    const Aabb& box = with.hull_box();
    ASSERT_FALSE(box.empty());
    const double reach = (box.max - box.min).norm();
    const Eigen::Vector3d outside = box.Center() + Eigen::Vector3d(0.8, 0.6, 0.5).normalized() * 1.5 * reach;
    const Eigen::Vector3d inside = box.Center() + 0.3 * (box.max - box.Center());
    int64_t skipped = 0;
    for (const Eigen::Vector3d& eye : {outside, inside}) {
      const Eigen::Vector3d up = -src->cameras()[0].cam_from_world.rotation.row(1).transpose();  // camera 0's up
      const NovelView view = NovelView::FromFov(96, 72, 1.2, LookAt(eye, box.Center(), up));
      PlaneSweepOptions o;
      o.num_planes = 100;
      const auto depths = SweepPlaneDepths(with, view, o);
      SweepStats st;
      const cv::Mat a = PlaneSweepCpu(with, view, depths, {0, 0, 96, 72}, &st, 2, 6);
      const cv::Mat b = PlaneSweepCpu(without, view, depths, {0, 0, 96, 72}, nullptr, 2, 6);
      skipped += st.skipped;
      const test::DepthDifference diff = test::CompareDepths(a, b);
      EXPECT_EQ(diff.differ, 0) << rig << (eye == outside ? ", from outside" : ", from inside");
      EXPECT_GT(diff.hull, 0) << rig;  // control: the view sees the hull
    }
    EXPECT_GT(skipped, 1000) << rig;  // control: the grid answered many queries
  }
}

// capture_node --image-region sends each camera's colour image only around its
// object pixels (ImageRectAroundObjectPixels), black elsewhere: on the real
// rigs (distorted, skewed) the hull is textured from such images exactly as
// from the whole ones, in views from outside and inside the hull box, with
// and without the visibility test, at capture's half-size images and at full
// size. Control: a region a third smaller changes the colours.
TEST(RigSource, RealRigsTextureFromTheirImagesObjectRegionsAsFromWholeImages) {
  for (const std::string& rig : test::RealRigs()) {
    const test::RealRigFrame first = test::FirstFrameOf(rig);
    if (!first.source) GTEST_SKIP() << rig << " not found (../shared beside the clone)";
    SCOPED_TRACE(rig);
    const auto& [src, f, views] = first;
    const VolumeQuery q(views, src->workspace());
    const Aabb& box = q.hull_box();
    ASSERT_FALSE(box.empty());
    PlaneSweepOptions vo;
    vo.num_planes = 48;
    const HullVisibility vis = ComputeHullVisibility(q, src->cameras(), 80, vo, 6, 2);
    for (const double scale : {0.5, 1.0}) {
      // Whole images, regions around the object pixels, and regions too small.
      std::vector<CameraImage> whole, region, small;
      size_t sent = 0, all = 0;
      for (size_t i = 0; i < src->cameras().size(); ++i) {
        cv::Mat img = f.images[i];
        if (scale < 1) cv::resize(img, img, cv::Size(), scale, scale, cv::INTER_AREA);
        const cv::Rect r = ImageRectAroundObjectPixels(cv::boundingRect(f.maps[i]), f.maps[i].size(), img.size());
        const cv::Rect less(r.x + r.width / 6, r.y + r.height / 6, r.width * 2 / 3, r.height * 2 / 3);
        whole.push_back({src->cameras()[i], img});
        for (auto [out, part] : {std::pair{&region, r}, std::pair{&small, less}}) {
          cv::Mat black(img.size(), CV_8UC3, cv::Scalar::all(0));
          img(part).copyTo(black(part));
          out->push_back({src->cameras()[i], black});
        }
        sent += size_t(r.area()), all += size_t(img.total());
      }
      EXPECT_LT(sent, all / 2) << "the regions are a part of the images";
      const double reach = (box.max - box.min).norm();
      const Eigen::Vector3d up = -src->cameras()[0].cam_from_world.rotation.row(1).transpose();  // camera 0's up
      double small_differs = 0;  // the most a colour differs from too small regions, in any view
      for (const Eigen::Vector3d& eye : {Eigen::Vector3d(box.Center() + Eigen::Vector3d(0.8, 0.6, 0.5).normalized() *
                                                                           1.5 * reach),
                                         Eigen::Vector3d(box.Center() + 0.3 * (box.max - box.Center()))}) {
        const NovelView view = NovelView::FromFov(120, 90, 1.2, LookAt(eye, box.Center(), up));
        PlaneSweepOptions o;
        o.num_planes = 100;
        const cv::Rect tile(0, 0, view.width, view.height);
        const cv::Mat depth = PlaneSweepCpu(q, view, SweepPlaneDepths(q, view, o), tile, nullptr, 2, 6);
        for (const HullVisibility* v : {&vis, static_cast<const HullVisibility*>(nullptr)}) {
          const cv::Mat want = TextureHull(depth, tile, view, whole, {}, v);
          EXPECT_GT(cv::countNonZero(want.reshape(1)), 100) << "hull pixels textured";
          EXPECT_EQ(cv::norm(TextureHull(depth, tile, view, region, {}, v), want, cv::NORM_INF), 0.0)
              << "scale " << scale << (v ? ", visibility" : "");
          small_differs = std::max(small_differs, cv::norm(TextureHull(depth, tile, view, small, {}, v), want,
                                                           cv::NORM_INF));
        }
      }
      EXPECT_GT(small_differs, 20.0) << "control: scale " << scale;
      std::printf("%s at scale %.1f: region pixels %zu of %zu\n", rig.c_str(), scale, sent, all);
    }
  }
}

}  // namespace
}  // namespace hullpipe

