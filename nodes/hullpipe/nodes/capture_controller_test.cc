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
  std::vector<std::pair<int64_t, double>> timelines;
  void AnnounceTimeline(int64_t start_ns, double fps) override { timelines.push_back({start_ns, fps}); }
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

TEST(Capture, ALateNodeJoinsTheSharedTimelineAtTheFrameDueNow) {
  // Two capture nodes of one run, one camera each, the second started 0.3 s after
  // the first: from the moment both run their frames carry the same numbers and
  // capture times, as one node's would.
  FakeClock clock;
  auto source_a = Synthetic(50), source_b = Synthetic(50);
  CaptureRecorder sink_a, sink_b;
  CaptureOptions o;
  CaptureController a(o, clock, *source_a, sink_a);
  a.Start();
  ASSERT_EQ(sink_a.timelines.size(), 1u);
  const int64_t start = sink_a.timelines[0].first;
  EXPECT_DOUBLE_EQ(sink_a.timelines[0].second, 25.0);
  for (int k = 0; k < 8; ++k) ASSERT_TRUE(a.Step());  // frames 1..8, the last due at 0.28 s
  clock.Advance(0.3 - 0.28);
  CaptureController b(o, clock, *source_b, sink_b);
  b.OnTimeline(start, 25.0);  // heard on the domain before starting
  b.Start();
  EXPECT_EQ(b.timeline_start_ns(), start);
  ASSERT_TRUE(b.Step());
  // Frame index 7 was due at 0.28 s, index 8 at 0.32 s: b joins at the frame due
  // now (index 7, 20 ms late) rather than at frame 1.
  const auto& first_b = sink_b.frames.front();
  EXPECT_EQ(first_b.seq, 8u);
  EXPECT_EQ(first_b.t_ns, start + 7 * 40'000'000);
  ASSERT_TRUE(a.Step());
  ASSERT_TRUE(b.Step());
  EXPECT_EQ(sink_a.frames.back().seq, sink_b.frames.back().seq);
  EXPECT_EQ(sink_a.frames.back().t_ns, sink_b.frames.back().t_ns);
  // b skipped frames 1..7 of its source: source times agree too.
  EXPECT_EQ(b.published(), 2);
}

TEST(Capture, NodesConvergeOnTheEarliestTimeline) {
  FakeClock clock;
  auto source = Synthetic(50);
  CaptureRecorder sink;
  CaptureOptions o;
  CaptureController c(o, clock, *source, sink);
  c.Start();  // nobody announced one yet: its own, now
  const int64_t own = c.timeline_start_ns();
  c.OnTimeline(own + 1'000'000, 25.0);  // later: ignored
  EXPECT_EQ(c.timeline_start_ns(), own);
  c.OnTimeline(own - 120'000'000, 30.0);  // another rate: ignored
  EXPECT_EQ(c.timeline_start_ns(), own);
  c.OnTimeline(own - 120'000'000, 25.0);  // earlier: adopted, 3 frames ahead
  ASSERT_TRUE(c.Step());
  EXPECT_EQ(sink.frames.front().seq, 4u);
  EXPECT_EQ(sink.frames.front().t_ns, own - 120'000'000 + 3 * 40'000'000);
  // A launcher-given start is never replaced.
  CaptureOptions given;
  given.start_ns = own + 5'000'000'000;  // 5 s in the future: Step waits in slices
  CaptureRecorder sink2;
  auto source2 = Synthetic(5);
  CaptureController d(given, clock, *source2, sink2);
  d.OnTimeline(own, 25.0);
  ASSERT_TRUE(d.Step());
  EXPECT_TRUE(sink2.frames.empty()) << "not due yet";
  EXPECT_EQ(d.timeline_start_ns(), given.start_ns);
}

}  // namespace
}  // namespace hullpipe::nodes
