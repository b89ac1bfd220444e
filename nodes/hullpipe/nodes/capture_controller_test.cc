#include "hullpipe/nodes/capture_controller.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <sstream>
#include <mutex>
#include <optional>
#include <random>
#include <set>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include "hullpipe/capture/prefetching_source.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/evaluation/synthetic_source.h"
#include "hullpipe/reconstruction/frameset.h"
#include "hullpipe/reconstruction/texture.h"
#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe::nodes {
namespace {

struct CaptureRecorder final : CaptureSink {
  bool concurrent = false;  ///< Say PublishFrame may run for several cameras at once.
  std::mutex mutex;
  std::set<std::thread::id> threads;  ///< Threads PublishFrame ran on.
  bool Concurrent() const override { return concurrent; }
  int infos = 0;
  PublishTimes times;  ///< What each PublishFrame reports it spent.
  struct Frame {
    uint32_t camera_id;
    uint64_t seq;
    int64_t t_ns;
    uint32_t count;
    cv::Size map, image;
    cv::Rect object;                     ///< The map's object pixels' bounding rectangle.
    std::optional<ImageRegion> region;   ///< Where the image lies in the whole scaled image.
    cv::Mat pixels;                      ///< The image's pixels.
  };
  std::vector<Frame> frames;
  void PublishCameraInfo(const Camera&, const Aabb&) override { ++infos; }
  std::vector<std::pair<int64_t, double>> timelines;
  void AnnounceTimeline(int64_t start_ns, double fps) override { timelines.push_back({start_ns, fps}); }
  PublishTimes PublishFrame(const CameraFrameOut& f) override {
    // A writer's work, so the other threads find cameras left to take.
    if (concurrent) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    const std::lock_guard<std::mutex> lock(mutex);
    threads.insert(std::this_thread::get_id());
    frames.push_back({f.stamp.camera_id, f.stamp.seq, f.stamp.capture_time_ns, f.camera_count, f.map.size(),
                      f.image.size(), cv::boundingRect(f.map), f.image_region, f.image.clone()});
    return times;
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

// A sink that allows it gets a frame's cameras from several threads at once,
// each camera once per frame with the frame's number and stamp; one that does
// not gets them all from the node's own thread (the control).
TEST(Capture, AConcurrentSinkGetsTheCamerasFromSeveralThreads) {
  for (const bool concurrent : {true, false}) {
    SCOPED_TRACE(concurrent ? "concurrent" : "one thread");
    FakeClock clock;
    auto source = Synthetic(3);
    CaptureRecorder sink;
    sink.concurrent = concurrent;
    CaptureOptions o;
    o.threads = 3;
    CaptureController c(o, clock, *source, sink);
    c.PublishCalibration();
    c.Start();
    for (int k = 0; k < 3; ++k) ASSERT_TRUE(c.Step());
    ASSERT_EQ(sink.frames.size(), 9u);
    for (uint64_t seq = 1; seq <= 3; ++seq) {
      std::set<uint32_t> ids;
      std::set<int64_t> stamps;
      for (const auto& f : sink.frames)
        if (f.seq == seq) ids.insert(f.camera_id), stamps.insert(f.t_ns);
      EXPECT_EQ(ids.size(), 3u) << "frame " << seq;
      EXPECT_EQ(stamps.size(), 1u) << "frame " << seq << ": one stamp for all its cameras";
    }
    if (concurrent)
      EXPECT_GT(sink.threads.size(), 1u);
    else
      EXPECT_EQ(sink.threads, std::set<std::thread::id>{std::this_thread::get_id()});
  }
  CaptureOptions bad;
  bad.threads = -1;
  EXPECT_THROW(bad.Check(), std::invalid_argument);
}

// Read one frame ahead (capture_node's default) or not, the same frames on the
// same timeline.
TEST(Capture, PacesAtTheSourceRateAndPublishesEveryCameraPerFrame) {
  for (const bool ahead : {false, true}) {
    SCOPED_TRACE(ahead ? "reading ahead" : "reading when due");
    FakeClock clock;
    auto source = ahead ? ReadAhead(Synthetic(4)) : Synthetic(4);
    EXPECT_EQ(dynamic_cast<PrefetchingSource*>(source.get()) != nullptr, ahead);
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
}

// --jpeg's default: raw images up to kAutoJpegAboveBytes a frame (the Utrecht
// rig), JPEG above (20 cameras of 1024x768); a quality given is kept.
TEST(Capture, ImagesGoOutAsJpegByDefaultOnlyWhenAFramesRawImagesAreLarge) {
  auto rig = [](int n, int w, int h) {
    std::vector<Camera> cams{size_t(n)};
    for (Camera& c : cams) c.width = w, c.height = h;
    return cams;
  };
  EXPECT_EQ(ImageJpegQuality(-1, rig(4, 644, 486), 0.5), 0);  // 0.94 MB
  EXPECT_EQ(ImageJpegQuality(-1, rig(20, 1024, 768), 0.5), kAutoJpegQuality);  // 11.8 MB
  EXPECT_EQ(ImageJpegQuality(-1, rig(16, 640, 480), 0.5), kAutoJpegQuality);  // 3.7 MB
  EXPECT_EQ(ImageJpegQuality(-1, rig(16, 640, 480), 0.25), 0);  // 0.92 MB
  EXPECT_EQ(ImageJpegQuality(-1, rig(4, 644, 486), 1.0), kAutoJpegQuality);  // 3.8 MB at full size
  EXPECT_EQ(ImageJpegQuality(0, rig(20, 1024, 768), 0.5), 0);
  EXPECT_EQ(ImageJpegQuality(75, rig(1, 64, 48), 0.5), 75);
  // --image-region auto decides by the same size.
  EXPECT_FALSE(ImageRegions("auto", rig(4, 644, 486), 0.5));
  EXPECT_TRUE(ImageRegions("auto", rig(20, 1024, 768), 0.5));
  EXPECT_TRUE(ImageRegions("object", rig(1, 64, 48), 0.5));
  EXPECT_FALSE(ImageRegions("whole", rig(20, 1024, 768), 0.5));
  EXPECT_THROW(ImageRegions("half", rig(1, 64, 48), 0.5), std::invalid_argument);
}

// --image-region object: each camera's image goes to the sink as only its
// region around the map's object pixels (all that texturing reads:
// ImageRectAroundObjectPixels), its pixels exactly those of the whole scaled
// image there; without it, whole.
TEST(Capture, ImagesGoOutAroundTheirObjectPixelsWhenAsked) {
  for (const bool regions : {true, false}) {
    SCOPED_TRACE(regions);
    FakeClock clock;
    auto source = Synthetic(2), same = Synthetic(2);
    CaptureRecorder sink;
    CaptureOptions o;
    o.image_scale = 0.5;
    o.image_regions = regions;
    CaptureController c(o, clock, *source, sink);
    c.Start();
    while (c.Step()) {
    }
    ASSERT_EQ(sink.frames.size(), 6u);
    RigFrame rf;  // the same frame from a second source: what was scaled
    for (size_t k = 0; k < sink.frames.size(); ++k) {
      const auto& f = sink.frames[k];
      if (k % 3 == 0) {
        ASSERT_TRUE(same->Next(&rf));
      }
      cv::Mat whole;
      cv::resize(rf.images[k % 3], whole, cv::Size(), 0.5, 0.5, cv::INTER_AREA);
      if (!regions) {
        EXPECT_EQ(cv::norm(f.pixels, whole, cv::NORM_INF), 0.0);
        EXPECT_FALSE(f.region);
        EXPECT_EQ(f.image, cv::Size(40, 30));
        continue;
      }
      ASSERT_TRUE(f.region);
      ASSERT_GT(f.object.area(), 0) << "the sphere is seen";
      EXPECT_EQ(f.region->whole, cv::Size(40, 30));
      EXPECT_EQ(f.region->rect, ImageRectAroundObjectPixels(f.object, f.map, f.region->whole));
      EXPECT_EQ(f.image, f.region->rect.size());
      EXPECT_EQ(cv::norm(f.pixels, whole(f.region->rect), cv::NORM_INF), 0.0) << "the whole scaled image's pixels";
      // The object rectangle at half size lies inside, with a margin.
      const cv::Rect half(f.object.x / 2, f.object.y / 2, (f.object.width + 1) / 2, (f.object.height + 1) / 2);
      const cv::Rect grown = (half + cv::Point(-2, -2) + cv::Size(4, 4)) & cv::Rect(cv::Point(0, 0), f.region->whole);
      EXPECT_EQ(f.region->rect & grown, grown);
      EXPECT_LT(f.region->rect.area(), f.region->whole.area());
    }
  }
}

// Only a region's source pixels are scaled where 1 / scale is a whole number
// dividing the image; every scale gives the whole image's scaled pixels there,
// to the bit (noise, so that any other averaging would differ), at the image's
// edges and for an empty region too.
TEST(Capture, AScaledImageRegionIsTheWholeScaledImagesPixels) {
  cv::Mat image(486, 644, CV_8UC3);
  cv::randu(image, 0, 256);
  for (const double scale : {1.0, 0.5, 0.25, 1.0 / 3, 0.4}) {
    SCOPED_TRACE(scale);
    cv::Mat whole = image;
    if (scale < 1) cv::resize(image, whole, cv::Size(), scale, scale, cv::INTER_AREA);
    EXPECT_EQ(ScaledImageSize(image.size(), scale), whole.size());
    for (const cv::Rect r :
         {cv::Rect(10, 7, 31, 19), cv::Rect(0, 0, 5, 5), cv::Rect(whole.cols - 9, whole.rows - 4, 9, 4),
          cv::Rect(whole.cols - 3, 2, 40, 40), cv::Rect()}) {
      const cv::Mat got = ScaledImageRegion(image, scale, r);
      const cv::Rect in = r & cv::Rect(cv::Point(0, 0), whole.size());
      ASSERT_EQ(got.size(), in.size()) << r;
      if (in.area()) {
        EXPECT_EQ(cv::norm(got, whole(in), cv::NORM_INF), 0.0) << r;
      }
    }
  }
  // An image whose size the factor does not divide: the whole image's pixels still.
  const cv::Mat odd = image(cv::Rect(0, 0, 643, 485));
  cv::Mat whole;
  cv::resize(odd, whole, cv::Size(), 0.5, 0.5, cv::INTER_AREA);
  const cv::Rect r(100, 50, 60, 40);
  EXPECT_EQ(cv::norm(ScaledImageRegion(odd, 0.5, r), whole(r), cv::NORM_INF), 0.0);
}

// The latency budget's capture stages (docs/latency.md): lag from the frame's
// due time to its read, the read (a source that does not split read and
// segmentation reports it all as read), and the sink's encode and write times
// summed over the frame's cameras.
// A sink whose publishing takes `per_camera` seconds of the fake clock: a
// machine too slow for the rig.
struct SlowSink final : CaptureSink {
  FakeClock* clock = nullptr;
  double per_camera = 0;
  int published = 0;
  void PublishCameraInfo(const Camera&, const Aabb&) override {}
  void AnnounceTimeline(int64_t, double) override {}
  PublishTimes PublishFrame(const CameraFrameOut&) override {
    clock->Advance(per_camera);
    ++published;
    return {};
  }
};

// A capture node that cannot keep the timeline's rate (25 fps, a frame taking
// 150 ms) says so once, with the rate it can keep and the flag that paces it,
// and how much of a file's input that skips, and skips the frames it cannot
// make, counted as dropped. A fast one says nothing (the control).
TEST(Capture, FallingBehindIsSaidOnceWithWhatWouldKeepUp) {
  for (const double per_camera : {0.05, 0.001}) {
    SCOPED_TRACE(per_camera);
    FakeClock clock;
    auto source = Synthetic(100);
    SlowSink sink;
    sink.clock = &clock;
    sink.per_camera = per_camera;
    auto lines = std::make_shared<std::ostringstream>();
    auto previous = spdlog::default_logger();
    spdlog::set_default_logger(
        std::make_shared<spdlog::logger>("capture", std::make_shared<spdlog::sinks::ostream_sink_mt>(*lines)));
    CaptureController c({}, clock, *source, sink);
    for (int k = 0; k < 40 && c.Step(); ++k) {
    }
    spdlog::set_default_logger(previous);
    const std::string log = lines->str();
    size_t said = 0;
    for (size_t at = log.find("cannot keep the timeline"); at != std::string::npos;
         at = log.find("cannot keep the timeline", at + 1))
      ++said;
    if (per_camera > 0.01) {
      EXPECT_EQ(said, 1u) << log;
      EXPECT_NE(log.find("150 ms"), std::string::npos) << log;
      EXPECT_NE(log.find("--fps 6.0"), std::string::npos) << log;  // 0.9 / 0.15 s
      // Said at the start, for the whole input: 100 frames at 25 fps, 6.7 made.
      EXPECT_NE(log.find("would skip about 73 of its 100 frames (most of its input)"), std::string::npos) << log;
      EXPECT_GT(c.counters().dropped(), 0u);
    } else {
      EXPECT_EQ(said, 0u) << log;
      EXPECT_EQ(c.counters().dropped(), 0u);
    }
  }
}

TEST(Capture, TimesTheBudgetsStagesFromTheFramesDueTime) {
  FakeClock clock;
  auto source = Synthetic(4);
  CaptureRecorder sink;
  sink.times = {1.5, 0.5};
  CaptureController c({}, clock, *source, sink);
  c.Start();
  clock.Advance(0.05);  // late: frame 1 (due at 0.04 s) is read at 0.05 s
  ASSERT_TRUE(c.Step());
  ASSERT_EQ(sink.frames.front().seq, 2u) << "joined at the frame due now";
  const auto& st = c.counters().stages();
  for (const char* s : {"lag", "read", "encode", "publish"}) ASSERT_TRUE(st.count(s)) << s;
  EXPECT_FALSE(st.count("segment")) << "the synthetic source does not time segmentation apart";
  EXPECT_NEAR(st.at("lag").Percentile(50), 10.0, 1e-3);
  EXPECT_NEAR(st.at("encode").Percentile(50), 3 * 1.5, 1e-9);  // three cameras; the fake clock stands still
  EXPECT_NEAR(st.at("publish").Percentile(50), 3 * 0.5, 1e-9);
}

// A source whose input ends early after `good` frames (a short camera): it
// wraps the synthetic source and says so through IncompleteEnd.
class EndsEarly final : public RigSource {
 public:
  EndsEarly(int good) : inner_(Synthetic(100)), good_(good) {}
  const std::vector<Camera>& cameras() const override { return inner_->cameras(); }
  int rig_camera_count() const override { return inner_->rig_camera_count(); }
  Aabb workspace() const override { return inner_->workspace(); }
  double fps() const override { return inner_->fps(); }
  bool Next(RigFrame* f) override { return read_++ < good_ && inner_->Next(f); }
  bool Rewind() override {
    read_ = 0;
    ++rewinds;
    return inner_->Rewind();
  }
  std::string IncompleteEnd() const override { return read_ > good_ ? "camera(s) 2 ended after frame 2" : ""; }
  int rewinds = 0;

 private:
  std::unique_ptr<RigSource> inner_;
  int good_, read_ = 0;
};

TEST(Capture, AnEarlyEndKeepsTheGoodFramesAndIsKept) {
  FakeClock clock;
  EndsEarly source(2);
  CaptureRecorder sink;
  CaptureOptions o;
  o.fast = true;
  CaptureController c(o, clock, source, sink);
  c.Start();
  EXPECT_TRUE(c.Step());
  EXPECT_TRUE(c.Step());
  EXPECT_EQ(c.incomplete(), "");
  EXPECT_FALSE(c.Step());
  EXPECT_EQ(c.published(), 2);
  EXPECT_EQ(c.incomplete(), "camera(s) 2 ended after frame 2");
  // --loop: rewound and going on, and the early end is still reported at the end.
  EndsEarly looped(2);
  CaptureRecorder sink2;
  o.loop = true;
  o.frames = 5;
  CaptureController l(o, clock, looped, sink2);
  l.Start();
  while (l.Step()) {
  }
  EXPECT_EQ(l.published(), 5);
  EXPECT_EQ(looped.rewinds, 2);
  EXPECT_EQ(l.incomplete(), "camera(s) 2 ended after frame 2");
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
  // Adopted while running: it rejoins at the frame due on the earlier timeline now
  // (a node left behind on the old one would never catch up at the frame rate).
  c.OnTimeline(own - 520'000'000, 25.0);
  ASSERT_TRUE(c.Step());
  EXPECT_EQ(sink.frames.back().seq, 14u) << "13 frames of 40 ms since the new start";
  EXPECT_EQ(sink.frames.back().t_ns, own - 520'000'000 + 13 * 40'000'000);
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

// A timeline announced by a hostile or broken peer: a start of 1 ns (1970)
// made a file-fed node skip its whole input, and with --loop try 4.5e10 frames
// past SIGINT. One outside the window is refused, said once and counted; one
// inside is adopted (the control), and a legitimately old timeline with --loop
// skips whole passes of the input without reading them.
TEST(Capture, ATimelineFarFromNowIsRefusedAndCounted) {
  FakeClock clock;
  auto source = Synthetic(50);
  CaptureRecorder sink;
  CaptureOptions o;
  CaptureController c(o, clock, *source, sink);
  const int64_t now = clock.WallNs();
  c.OnTimeline(1, 25.0);
  c.OnTimeline(now - 601'000'000'000, 25.0);
  c.OnTimeline(now + 3'600'000'000'000, 25.0);
  c.OnTimeline(now - 100'000'000, std::nan(""));  // a rate that is not one
  EXPECT_EQ(c.timelines_refused(), 3);
  c.Start();
  EXPECT_EQ(c.timeline_start_ns(), now) << "its own";
  c.OnTimeline(now - 599'000'000'000, 25.0);  // control: inside the window, adopted
  EXPECT_EQ(c.timeline_start_ns(), now - 599'000'000'000);
  EXPECT_EQ(c.timelines_refused(), 3);
  CaptureOptions bad;
  bad.timeline_window_s = 0;
  EXPECT_THROW(bad.Check(), std::invalid_argument);

  // --loop on a 10-frame input, joining a timeline 500 s old: 12,500 frames are
  // due; whole passes are skipped without reading, and the first frame
  // published is the one due now, in few steps.
  auto looping = Synthetic(10);
  CaptureRecorder sink2;
  CaptureOptions lo;
  lo.loop = true;
  CaptureController l(lo, clock, *looping, sink2);
  l.OnTimeline(now - 500'000'000'000, 25.0);
  l.Start();
  int steps = 0;
  while (sink2.frames.empty() && steps < 100) {
    ASSERT_TRUE(l.Step());
    ++steps;
  }
  ASSERT_FALSE(sink2.frames.empty());
  EXPECT_LE(steps, 2);
  EXPECT_EQ(sink2.frames.front().seq, 12'501u);
  EXPECT_EQ(sink2.frames.front().t_ns, now - 500'000'000'000 + 12'500 * 40'000'000LL);
}

// Four cameras 192x144 at 25 fps around the sphere, camera 2 moving on
// SyntheticTrackedPose's path.
SyntheticRigOptions TrackedSphereRig(int frames) {
  SyntheticRigOptions so;
  so.cameras = 4;
  so.width = 192;
  so.height = 144;
  so.fps = 25;
  so.frames = frames;
  so.scene = "sphere";
  so.tracked_camera = 2;
  return so;
}

// A sink that assembles framesets as recon does, keeping each camera's pose.
struct ToAssembler final : CaptureSink {
  FramesetAssembler a{8};
  std::vector<std::pair<uint32_t, std::optional<Rigid3d>>> sent;  ///< camera id, pose of each frame out
  void PublishCameraInfo(const Camera& c, const Aabb& ws) override {
    a.SetCamera(c);
    a.SetWorkspace(ws);
  }
  PublishTimes PublishFrame(const CameraFrameOut& f) override {
    const auto pose = f.cam_from_world ? std::optional<Rigid3d>(*f.cam_from_world) : std::nullopt;
    sent.push_back({f.stamp.camera_id, pose});
    a.AddMap(MapSample{.camera_id = int(f.stamp.camera_id), .seq = f.stamp.seq,
        .capture_time_ns = f.stamp.capture_time_ns, .camera_count = int(f.camera_count), .map = f.map.clone(),
        .source_time_s = f.stamp.source_time_s, .source_id = 0, .arrival_ns = 0, .cam_from_world = pose});
    return {};
  }
  void AnnounceTimeline(int64_t, double) override {}
};

// Ground truth for a tracked camera's frameset: the visual hull contains the
// object, so every point 3 cm inside the synthetic sphere (more than a pixel:
// a pixel spans 2.3 cm at the sphere, 1 rad over 192 pixels 4.5 m away) must
// be inside the hull of the frameset's maps; the same maps with the calibrated
// (unmoved) pose for the tracked camera are the control: they carve the sphere
// away.
void ExpectTheHullHoldsTheSphere(const Frameset& fs, const Aabb& workspace, const Camera& calibrated,
                                 size_t tracked_index) {
  const SyntheticScene scene = NamedScene("sphere", fs.source_time_s);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  std::vector<Eigen::Vector3d> inside;
  while (inside.size() < 2000) {
    const Eigen::Vector3d p = Eigen::Vector3d(0, 0, -1.0) + Eigen::Vector3d(u(rng), u(rng), u(rng));
    double d = 1e9;
    for (const auto& sh : scene.shapes) d = std::min(d, sh.SignedDistance(p));
    if (d < -0.03) inside.push_back(p);
  }
  auto misses = [&](const std::vector<CameraMap>& maps) {
    const VolumeQuery hull(maps, workspace);
    return std::count_if(inside.begin(), inside.end(), [&](const Eigen::Vector3d& p) { return !hull.Inside(p); });
  };
  EXPECT_EQ(misses(fs.maps), 0);
  std::vector<CameraMap> unmoved = fs.maps;
  unmoved[tracked_index].camera = calibrated;
  EXPECT_GT(misses(unmoved), 100) << "control: the calibrated pose must carve the moved camera's sphere away";
}

// The paper's head-mounted camera: a tracked camera's pose travels with each of
// its frames and the frameset uses it. Ground truth: the visual hull contains the
// object, so every point 3 cm (more than a pixel) inside the synthetic sphere must be inside
// the hull built from the frameset; the same maps with the calibrated (unmoved)
// pose for the tracked camera are the control — they carve the sphere away.
TEST(Capture, ATrackedCameraSendsItsPoseAndTheHullUsesIt) {
  FakeClock clock;
  const SyntheticRigOptions so = TrackedSphereRig(10);
  auto source = OpenSyntheticRig(so);
  ToAssembler sink;
  CaptureController c({}, clock, *source, sink);
  c.PublishCalibration();
  c.Start();
  for (int k = 0; k < 7; ++k) ASSERT_TRUE(c.Step());  // frame 6 at 0.24 s: the camera has moved 4.8 deg
  auto fs = sink.a.TakeNewest();
  ASSERT_TRUE(fs);
  const Camera& calibrated = source->cameras()[1];
  const Rigid3d expected = SyntheticTrackedPose(calibrated, Eigen::Vector3d(0, 0, -1.0), fs->source_time_s);
  ASSERT_EQ(fs->maps[1].camera.id, 2);
  EXPECT_LT((fs->maps[1].camera.cam_from_world.rotation - expected.rotation).norm(), 1e-12);
  EXPECT_LT((fs->maps[1].camera.cam_from_world.translation - expected.translation).norm(), 1e-12);
  const Eigen::Vector3d moved_centre = expected.Inverse().translation;
  EXPECT_GT((moved_centre - calibrated.Center()).norm(), 0.2) << "the camera moved";
  ExpectTheHullHoldsTheSphere(*fs, sink.a.workspace(), calibrated, 1);
}

// The same camera posed live (rig 'tracked: topic'): its frames carry no pose;
// a tracker's samples at 200 Hz, 2.5 ms off the frames' times, arrive as
// CameraPose, the one after each frame's time by the time it is posed (as for a
// live camera, whose frame arrives after its exposure). Each frame takes the
// pose interpolated at its capture time: the path's own pose to 1e-5 (linear
// interpolation over 5 ms of a path turning at most 0.35 rad/s and moving at
// most 0.6 m/s errs by about 2e-6; a frame posed by the sample before it,
// 2.5 ms stale, is 1e-3 off), and the hull
// holds the sphere (the calibrated pose, the control, carves it away). When the
// tracker stops, the camera's frames are not published and are counted; the
// other cameras' still are.
TEST(Capture, ACameraPosedLiveByATrackerTakesThePoseAtItsFramesTime) {
  FakeClock clock;
  const SyntheticRigOptions so = TrackedSphereRig(30);
  // The synthetic source moves camera 2 and says its pose with each frame;
  // posed live, the pose must come from the tracker instead.
  struct PosedLive final : RigSource {
    std::unique_ptr<RigSource> inner;
    const std::vector<Camera>& cameras() const override { return inner->cameras(); }
    int rig_camera_count() const override { return inner->rig_camera_count(); }
    Aabb workspace() const override { return inner->workspace(); }
    double fps() const override { return inner->fps(); }
    bool Next(RigFrame* f) override {
      const bool ok = inner->Next(f);
      f->poses.clear();
      return ok;
    }
    bool Rewind() override { return inner->Rewind(); }
    std::vector<bool> tracked_by_topic() const override { return {false, true, false, false}; }
  } source;
  source.inner = OpenSyntheticRig(so);
  ToAssembler sink;
  CaptureController c({}, clock, source, sink);
  const Camera calibrated = source.cameras()[1];
  const Eigen::Vector3d target(0, 0, -1.0);
  // The tracker: samples at start + 2.5 ms + k 5 ms, up to 5 ms past now, until it stops.
  int64_t next_sample = -1, tracker_stops = INT64_MAX;
  c.SetPoseRefresh([&] {
    const int64_t start = c.timeline_start_ns();
    if (next_sample < 0) next_sample = start + 2'500'000 - 50'000'000;
    for (; next_sample <= clock.WallNs() + 5'000'000 && next_sample < tracker_stops; next_sample += 5'000'000) {
      const double t = double(next_sample - start) * 1e-9;  // the source's time at that instant
      c.OnCameraPose(2, next_sample, SyntheticTrackedPose(calibrated, target, t).Inverse());
    }
  });
  c.OnCameraPose(7, 0, Rigid3d{});  // another node's camera: ignored, not counted
  c.PublishCalibration();
  c.Start();
  for (int k = 0; k < 7; ++k) ASSERT_TRUE(c.Step());
  EXPECT_EQ(c.unposed_frames(), 0);
  EXPECT_EQ(c.counters().rejected(), 0);
  auto fs = sink.a.TakeNewest();
  ASSERT_TRUE(fs);
  const Rigid3d expected = SyntheticTrackedPose(calibrated, target, fs->source_time_s);
  ASSERT_EQ(fs->maps[1].camera.id, 2);
  EXPECT_LT((fs->maps[1].camera.cam_from_world.rotation - expected.rotation).norm(), 1e-5);
  EXPECT_LT((fs->maps[1].camera.cam_from_world.translation - expected.translation).norm(), 1e-5);
  EXPECT_GT((expected.Inverse().translation - calibrated.Center()).norm(), 0.2) << "the camera moved";
  ExpectTheHullHoldsTheSphere(*fs, sink.a.workspace(), calibrated, 1);

  // The tracker stops: once its last sample is more than 50 ms behind a frame,
  // camera 2's frames are held back and counted; the others go on.
  tracker_stops = clock.WallNs();
  const auto sent_before = sink.sent.size();
  for (int k = 0; k < 5; ++k) ASSERT_TRUE(c.Step());
  EXPECT_GE(c.unposed_frames(), 3);
  EXPECT_EQ(c.counters().rejected(), c.unposed_frames());
  int camera2 = 0, others = 0;
  for (size_t i = sent_before; i < sink.sent.size(); ++i) (sink.sent[i].first == 2 ? camera2 : others)++;
  EXPECT_EQ(others, 15);
  EXPECT_EQ(camera2, 5 - c.unposed_frames());
  for (size_t i = 0; i < sink.sent.size(); ++i)
    EXPECT_EQ(sink.sent[i].second.has_value(), sink.sent[i].first == 2) << "only the tracked camera carries a pose";
}

}  // namespace
}  // namespace hullpipe::nodes
