#include "hullpipe/nodes/capture_controller.h"

#include <gtest/gtest.h>

namespace hullpipe::nodes {
namespace {

struct CaptureRecorder final : CaptureSink {
  int infos = 0;
  struct Frame {
    uint32_t camera_id;
    uint64_t seq;
    int64_t t_ns;
    uint32_t count;
    cv::Size map, image;
  };
  std::vector<Frame> frames;
  void PublishCameraInfo(const Camera&, const Aabb&) override { ++infos; }
  void PublishFrame(uint32_t id, uint64_t seq, int64_t t_ns, double, uint32_t count, const cv::Mat& map,
                    const cv::Mat& image) override {
    frames.push_back({id, seq, t_ns, count, map.size(), image.size()});
  }
};

std::unique_ptr<RigSource> Synthetic(int frames) {
  SyntheticRigOptions so;
  so.cameras = 3;
  so.width = 80;
  so.height = 60;
  so.fps = 25;
  so.frames = frames;
  so.scene = "sphere";
  return OpenSyntheticRig(so);
}

TEST(Capture, PacesAtTheSourceRateAndPublishesEveryCameraPerFrame) {
  FakeClock clock;
  auto source = Synthetic(4);
  CaptureRecorder sink;
  CaptureOptions o;
  o.image_scale = 0.5;
  CaptureController c(o, clock, *source, sink);
  c.PublishCalibration();
  EXPECT_EQ(sink.infos, 3);
  c.Start();
  const double t0 = clock.Now();
  for (int k = 0; k < 4; ++k) ASSERT_TRUE(c.Step());
  EXPECT_NEAR(clock.Now() - t0, 3.0 / 25.0, 1e-9) << "frame k is due at k / fps";
  EXPECT_FALSE(c.Step()) << "end of input";
  EXPECT_EQ(c.published(), 4);
  ASSERT_EQ(sink.frames.size(), 12u);
  EXPECT_EQ(sink.frames.back().seq, 4u);
  EXPECT_EQ(sink.frames.back().count, 3u);
  EXPECT_EQ(sink.frames.back().map, cv::Size(80, 60));
  EXPECT_EQ(sink.frames.back().image, cv::Size(40, 30));
  EXPECT_EQ(sink.frames[3].t_ns - sink.frames[0].t_ns, 40'000'000) << "capture times 1/25 s apart";
}

TEST(Capture, StopsAfterFramesAndLoopsWhenAsked) {
  FakeClock clock;
  auto source = Synthetic(3);
  CaptureRecorder sink;
  CaptureOptions o;
  o.frames = 5;
  o.loop = true;
  o.fast = true;
  CaptureController c(o, clock, *source, sink);
  int steps = 0;
  while (c.Step()) ++steps;
  EXPECT_EQ(steps, 5) << "3 frames, rewound, 2 more";
  EXPECT_EQ(clock.Now(), FakeClock().Now()) << "unpaced: no waiting";
  CaptureOptions bad;
  bad.image_scale = 0;
  EXPECT_THROW(bad.Check(), std::invalid_argument);
  bad = {};
  bad.fps = -1;
  EXPECT_THROW(bad.Check(), std::invalid_argument);
}

}  // namespace
}  // namespace hullpipe::nodes
