#include "hullpipe/reconstruction/frameset.h"

#include <gtest/gtest.h>

#include "hullpipe/evaluation/synthetic.h"

namespace hullpipe {
namespace {

class Assembler : public ::testing::Test {
 protected:
  Assembler() : cams_(RingCameras(3, 3, 2, Eigen::Vector3d::Zero(), 32, 24, 1.0)) {}
  cv::Mat Map() const { return cv::Mat(24, 32, CV_8UC1, cv::Scalar(255)); }
  std::vector<Camera> cams_;
};

TEST_F(Assembler, CompletesWhenAllCamerasArrived) {
  FramesetAssembler a(4);
  for (const auto& c : cams_) a.SetCamera(c);
  EXPECT_TRUE(a.AddMap(1, 7, 100, 3, Map()));
  EXPECT_TRUE(a.AddMap(2, 7, 100, 3, Map()));
  EXPECT_FALSE(a.IsComplete(7));
  EXPECT_TRUE(a.AddMap(3, 7, 100, 3, Map(), nullptr, 0.28));
  ASSERT_TRUE(a.IsComplete(7));
  const auto f = a.Take(7);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->maps.size(), 3u);
  EXPECT_DOUBLE_EQ(f->source_time_s, 0.28);
  EXPECT_EQ(f->capture_time_ns, 100);
  EXPECT_TRUE(a.IsGone(7));
  EXPECT_FALSE(a.AddMap(1, 6, 90, 3, Map()));  // older than what was taken: dropped
  EXPECT_EQ(a.dropped(), 1u);
}

TEST_F(Assembler, ARestartedCaptureIsTakenNotDropped) {
  FramesetAssembler a(4);
  for (const auto& c : cams_) a.SetCamera(c);
  for (int c = 1; c <= 3; ++c) a.AddMap(c, 500, 100, 3, Map());
  ASSERT_TRUE(a.Take(500));
  EXPECT_FALSE(a.AddMap(1, 490, 90, 3, Map()));  // merely late: dropped
  EXPECT_EQ(a.restarts(), 0u);
  for (int c = 1; c <= 3; ++c) EXPECT_TRUE(a.AddMap(c, 1, 200, 3, Map()));  // frame numbers start over
  EXPECT_EQ(a.restarts(), 1u);
  EXPECT_TRUE(a.IsComplete(1));
  EXPECT_TRUE(a.TakeNewest());
}

TEST_F(Assembler, LatestWinsWithBoundedMemory) {
  FramesetAssembler a(2);
  for (const auto& c : cams_) a.SetCamera(c);
  for (uint64_t s = 1; s <= 10; ++s)
    for (int id = 1; id <= 3; ++id) a.AddMap(id, s, int64_t(s), 3, Map());
  EXPECT_EQ(a.NewestComplete(), 10u);
  const auto f = a.TakeNewest();
  ASSERT_TRUE(f);
  EXPECT_EQ(f->seq, 10u);
  EXPECT_EQ(a.dropped(), 9u);  // 8 evicted by the bound + frame 9 superseded
  EXPECT_FALSE(a.TakeNewest());
}

TEST_F(Assembler, MapsBeforeCameraInfoAreParkedThenChecked) {
  FramesetAssembler a(4);
  EXPECT_TRUE(a.AddMap(1, 1, 0, 3, Map()));
  EXPECT_TRUE(a.AddMap(2, 1, 0, 3, Map()));
  EXPECT_TRUE(a.AddMap(3, 1, 0, 3, cv::Mat(5, 5, CV_8UC1)));  // wrong size, unknown yet
  EXPECT_FALSE(a.IsComplete(1));
  for (const auto& c : cams_) a.SetCamera(c);
  EXPECT_EQ(a.rejected(), 1u);  // camera 3's map did not fit its calibration
  EXPECT_FALSE(a.IsComplete(1));
  EXPECT_TRUE(a.AddMap(3, 1, 0, 3, Map()));
  EXPECT_TRUE(a.IsComplete(1));
}

TEST_F(Assembler, UnknownCameraIsRejectedWhenItsFrameIsEvicted) {
  FramesetAssembler a(1);
  for (const auto& c : cams_) a.SetCamera(c);
  a.AddMap(99, 1, 0, 3, Map());  // no CameraInfo for camera 99
  a.AddMap(1, 2, 0, 3, Map());   // evicts frame 1
  EXPECT_EQ(a.rejected(), 1u);
  std::string why;
  EXPECT_FALSE(a.AddMap(1, 3, 0, 3, cv::Mat(24, 31, CV_8UC1), &why));
  EXPECT_NE(why.find("calibration says 32x24"), std::string::npos) << why;
  EXPECT_FALSE(a.AddMap(1, 3, 0, 0, Map(), &why));  // camera_count out of range
}

TEST_F(Assembler, MapsEvictedBeforeALateCameraInfoAreDroppedNotRejected) {
  // DDS does not order samples across topics: under load a camera's CameraInfo
  // can come after a few of its frames were already evicted. That is a start-up
  // race, not bad input.
  FramesetAssembler a(1);
  a.SetCamera(cams_[0]);
  a.SetCamera(cams_[1]);
  a.AddMap(3, 1, 0, 3, Map());  // camera 3's calibration is late
  a.AddMap(1, 2, 0, 3, Map());  // evicts frame 1
  EXPECT_EQ(a.rejected(), 1u);
  const uint64_t dropped = a.dropped();
  a.SetCamera(cams_[2]);  // id 3 arrives
  EXPECT_EQ(a.rejected(), 0u);
  EXPECT_EQ(a.dropped(), dropped + 1);
}

TEST_F(Assembler, ImagesCanBeRequired) {
  FramesetAssembler a(4, true);
  for (const auto& c : cams_) a.SetCamera(c);
  for (int id = 1; id <= 3; ++id) a.AddMap(id, 1, 0, 3, Map());
  EXPECT_FALSE(a.IsComplete(1));
  for (int id = 1; id <= 3; ++id) a.AddImage(id, 1, 0, cv::Mat(12, 16, CV_8UC3, cv::Scalar(1, 2, 3)));
  ASSERT_TRUE(a.IsComplete(1));
  EXPECT_EQ(a.Take(1)->images.size(), 3u);
}

}  // namespace
}  // namespace hullpipe
