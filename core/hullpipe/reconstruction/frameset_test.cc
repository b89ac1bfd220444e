#include "hullpipe/reconstruction/frameset.h"

#include <algorithm>
#include <random>

#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <memory>
#include <sstream>

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
  EXPECT_TRUE(a.AddMap(MapSample{.camera_id = 1, .seq = 7, .capture_time_ns = 100, .camera_count = 3, .map = Map(),
      .source_time_s = 0.28}));  // the reference camera's source time counts
  EXPECT_TRUE(a.AddMap(MapSample{.camera_id = 2, .seq = 7, .capture_time_ns = 100, .camera_count = 3, .map = Map()}));
  EXPECT_FALSE(a.IsComplete(7));
  EXPECT_TRUE(a.AddMap(MapSample{.camera_id = 3, .seq = 7, .capture_time_ns = 100, .camera_count = 3, .map = Map()}));
  ASSERT_TRUE(a.IsComplete(7));
  const auto f = a.Take(7);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->maps.size(), 3u);
  EXPECT_DOUBLE_EQ(f->source_time_s, 0.28);
  EXPECT_EQ(f->capture_time_ns, 100);
  EXPECT_TRUE(a.IsGone(7));
  EXPECT_FALSE(a.AddMap(MapSample{.camera_id = 1, .seq = 6, .capture_time_ns = 90, .camera_count = 3,
      .map = Map()}));  // older than what was taken: dropped
  EXPECT_EQ(a.dropped(), 1u);
}

TEST_F(Assembler, ARestartedCaptureIsTakenNotDropped) {
  FramesetAssembler a(4);
  for (const auto& c : cams_) a.SetCamera(c);
  for (int c = 1; c <= 3; ++c) a.AddMap(MapSample{.camera_id = c, .seq = 500, .capture_time_ns = 100,
      .camera_count = 3, .map = Map()});
  ASSERT_TRUE(a.Take(500));
  EXPECT_FALSE(a.AddMap(MapSample{.camera_id = 1, .seq = 490, .capture_time_ns = 90, .camera_count = 3,
      .map = Map()}));  // merely late: dropped
  EXPECT_EQ(a.restarts(), 0u);
  for (int c = 1; c <= 3; ++c) EXPECT_TRUE(a.AddMap(MapSample{.camera_id = c, .seq = 1, .capture_time_ns = 200,
      .camera_count = 3, .map = Map()}));  // frame numbers start over
  EXPECT_EQ(a.restarts(), 1u);
  EXPECT_TRUE(a.IsComplete(1));
  EXPECT_TRUE(a.TakeNewest());
}

TEST_F(Assembler, LatestWinsWithBoundedMemory) {
  FramesetAssembler a(2);
  for (const auto& c : cams_) a.SetCamera(c);
  for (uint64_t s = 1; s <= 10; ++s)
    for (int id = 1; id <= 3; ++id) a.AddMap(MapSample{.camera_id = id, .seq = s, .capture_time_ns = int64_t(s),
        .camera_count = 3, .map = Map()});
  EXPECT_EQ(a.NewestComplete(), 10u);
  const auto f = a.TakeNewest();
  ASSERT_TRUE(f);
  EXPECT_EQ(f->seq, 10u);
  EXPECT_EQ(a.dropped(), 9u);  // 8 evicted by the bound + frame 9 superseded
  EXPECT_FALSE(a.TakeNewest());
  // Every one was a complete frameset when it was passed over.
  EXPECT_EQ(a.reference_frames(), 10u);
  EXPECT_EQ(a.framesets_complete(), 10u);
}

// The framesets the streams made, counted apart from how many a slow consumer took.
TEST_F(Assembler, CountsCompleteFramesetsWhateverTheConsumerTakes) {
  FramesetAssembler a(8);
  for (const auto& c : cams_) a.SetCamera(c);
  const int64_t period = 40'000'000;  // 25 fps
  for (uint64_t s = 1; s <= 6; ++s)
    for (int id = 1; id <= 3; ++id)
      if (!(id == 3 && (s == 2 || s == 3))) a.AddMap(MapSample{.camera_id = id, .seq = s,
          .capture_time_ns = int64_t(s) * period, .camera_count = 3, .map = Map()});  // camera 3 misses 2, 3
  ASSERT_TRUE(a.Take(6));  // the newest only: 1..5 passed over
  EXPECT_EQ(a.reference_frames(), 6u);
  // 1, 4, 5 and 6 complete; 2 and 3 have camera 3's nearest a period away, outside
  // the half-period tolerance.
  EXPECT_EQ(a.framesets_complete(), 4u);
  EXPECT_EQ(a.dropped_for_skew(), 2u);
}

TEST_F(Assembler, MapsBeforeCameraInfoAreParkedThenChecked) {
  FramesetAssembler a(4);
  EXPECT_TRUE(a.AddMap(MapSample{.camera_id = 1, .seq = 1, .capture_time_ns = 0, .camera_count = 3, .map = Map()}));
  EXPECT_TRUE(a.AddMap(MapSample{.camera_id = 2, .seq = 1, .capture_time_ns = 0, .camera_count = 3, .map = Map()}));
  EXPECT_TRUE(a.AddMap(MapSample{.camera_id = 3, .seq = 1, .capture_time_ns = 0, .camera_count = 3,
      .map = cv::Mat(5, 5, CV_8UC1)}));  // wrong size, unknown yet
  EXPECT_FALSE(a.IsComplete(1));
  for (const auto& c : cams_) a.SetCamera(c);
  EXPECT_EQ(a.rejected(), 1u);  // camera 3's map did not fit its calibration
  EXPECT_FALSE(a.IsComplete(1));
  EXPECT_TRUE(a.AddMap(MapSample{.camera_id = 3, .seq = 1, .capture_time_ns = 0, .camera_count = 3, .map = Map()}));
  EXPECT_TRUE(a.IsComplete(1));
}

// A received map's size is checked against the calibration before it is
// decoded: the fuzzer's 16384x12288 map of one run (201 Mpixel, legal on its
// own) took 15 s to decode and re-encode under the sanitizers.
TEST_F(Assembler, AMapSizeIsCheckedBeforeDecodingOnceTheCameraIsKnown) {
  FramesetAssembler a(4);
  EXPECT_TRUE(a.CheckMapSize(1, 16384, 12288));  // no calibration yet: decoded, parked, checked later
  for (const auto& c : cams_) a.SetCamera(c);
  std::string why;
  EXPECT_FALSE(a.CheckMapSize(1, 16384, 12288, &why));
  EXPECT_EQ(why, "map of camera 1 is 16384x12288, calibration says 32x24");
  EXPECT_EQ(a.rejected(), 1u);
  EXPECT_TRUE(a.CheckMapSize(1, 32, 24));  // control: the calibration's size
  EXPECT_EQ(a.rejected(), 1u);
}

// A CameraInfo that changes a camera mid-run (a hostile peer, or a capture
// node restarted on another calibration): its size changed rejected every map
// and ended the run with exit 0; a pose moved 0.3 m was taken silently and
// carved the person away. The first calibration holds; the change is refused,
// named and counted. Control: the same calibration again (a restarted
// capture node's) changes nothing and maps of the first size go on.
TEST_F(Assembler, ACalibrationChangedMidRunIsRefusedNamedAndCounted) {
  FramesetAssembler a(4);
  for (const auto& c : cams_) EXPECT_TRUE(a.SetCamera(c));
  for (const auto& c : cams_) EXPECT_TRUE(a.SetCamera(c)) << "the same again";
  std::string why;
  Camera resized = cams_[0];
  resized.width = 16;
  resized.height = 12;
  EXPECT_FALSE(a.SetCamera(resized, &why));
  EXPECT_EQ(why, "camera 1: a CameraInfo that changes its calibration mid-run (size 32x24 -> 16x12): refused, the "
                 "first one holds (a recalibrated rig is a new run)");
  Camera moved = cams_[1];
  moved.cam_from_world.translation += moved.cam_from_world.rotation * Eigen::Vector3d(0.3, 0, 0);
  EXPECT_FALSE(a.SetCamera(moved, &why));
  EXPECT_NE(why.find("pose (centre moved 0.3 m, turned 0 deg)"), std::string::npos) << why;
  Camera refocused = cams_[2];
  refocused.fx *= 1.01;
  refocused.distortion[0] = 0.1;
  EXPECT_FALSE(a.SetCamera(refocused, &why));
  EXPECT_NE(why.find("(intrinsics K, distortion)"), std::string::npos) << why;
  EXPECT_EQ(a.calibrations_refused(), 3u);
  for (int c = 1; c <= 3; ++c)
    EXPECT_TRUE(a.AddMap(MapSample{.camera_id = c, .seq = 1, .capture_time_ns = 100, .camera_count = 3, .map = Map()}));
  ASSERT_TRUE(a.IsComplete(1)) << "the first calibrations hold: maps of their size go on";
  Aabb box;
  box.min = Eigen::Vector3d(-1, -1, -1);
  box.max = Eigen::Vector3d(1, 1, 1);
  EXPECT_TRUE(a.SetWorkspace(box));
  EXPECT_TRUE(a.SetWorkspace(box));
  Aabb other = box;
  other.max.x() = 2;
  EXPECT_FALSE(a.SetWorkspace(other, &why));
  EXPECT_EQ(a.calibrations_refused(), 4u);
  EXPECT_EQ(a.workspace().max.x(), 1);
}

// With a camera per capture node, a truncated video ends that node's input
// early and it cannot tell (it has no other camera): the assembler, which sees
// every camera, names it. A camera ending 0.8 s before the last (within the
// 1-s floor: live streams end that raggedly) is not early: the control.
TEST_F(Assembler, ACameraWhoseInputEndedEarlyIsNamed) {
  FramesetAssembler a(4);
  for (const auto& c : cams_) a.SetCamera(c);
  const int64_t period = 40'000'000;  // 25 fps
  for (uint64_t f = 1; f <= 100; ++f)
    for (int cam = 1; cam <= 3; ++cam) {
      if (cam == 2 && f > 40) continue;  // camera 2's video was cut at frame 40
      if (cam == 3 && f > 80) continue;  // camera 3 ends 0.8 s before camera 1: a live stream's end, not early
      a.AddMap(MapSample{.camera_id = cam, .seq = f, .capture_time_ns = int64_t(f) * period + cam * 1000,
          .camera_count = 3, .map = Map()});
    }
  const auto early = a.EndedEarly();
  ASSERT_EQ(early.size(), 1u);
  EXPECT_EQ(early[0].camera_id, 2);
  EXPECT_EQ(early[0].frames, 40u);
  EXPECT_NEAR(early[0].lag_s, 60 * 0.04, 1e-4);
  // A calibrated camera that sent nothing ended early too.
  FramesetAssembler silent(4);
  for (const auto& c : cams_) silent.SetCamera(c);
  for (uint64_t f = 1; f <= 10; ++f) silent.AddMap(MapSample{.camera_id = 1, .seq = f,
      .capture_time_ns = int64_t(f) * period, .camera_count = 3, .map = Map()});
  ASSERT_EQ(silent.EndedEarly().size(), 2u);
  EXPECT_EQ(silent.EndedEarly()[1].camera_id, 3);
}

TEST_F(Assembler, UnknownCameraIsRejectedWhenItsFrameIsEvicted) {
  FramesetAssembler a(1);  // history of 3 samples per camera
  for (const auto& c : cams_) a.SetCamera(c);
  for (uint64_t s = 1; s <= 4; ++s) a.AddMap(MapSample{.camera_id = 99, .seq = s, .capture_time_ns = int64_t(s),
      .camera_count = 3, .map = Map()});  // no CameraInfo for camera 99
  EXPECT_EQ(a.rejected(), 1u);  // its first map left the history
  std::string why;
  EXPECT_FALSE(a.AddMap(MapSample{.camera_id = 1, .seq = 3, .capture_time_ns = 0, .camera_count = 3,
      .map = cv::Mat(24, 31, CV_8UC1)}, &why));
  EXPECT_NE(why.find("calibration says 32x24"), std::string::npos) << why;
  EXPECT_FALSE(a.AddMap(MapSample{.camera_id = 1, .seq = 3, .capture_time_ns = 0, .camera_count = 0,
      .map = Map()}, &why));  // camera_count out of range
}

TEST_F(Assembler, MapsEvictedBeforeALateCameraInfoAreDroppedNotRejected) {
  // DDS does not order samples across topics: under load a camera's CameraInfo
  // can come after a few of its frames were already evicted. That is a start-up
  // race, not bad input.
  FramesetAssembler a(1);
  a.SetCamera(cams_[0]);
  a.SetCamera(cams_[1]);
  for (uint64_t s = 1; s <= 4; ++s) a.AddMap(MapSample{.camera_id = 3, .seq = s, .capture_time_ns = int64_t(s),
      .camera_count = 3, .map = Map()});  // camera 3's calibration is late
  EXPECT_EQ(a.rejected(), 1u);
  const uint64_t dropped = a.dropped();
  a.SetCamera(cams_[2]);  // id 3 arrives
  EXPECT_EQ(a.rejected(), 0u);
  EXPECT_EQ(a.dropped(), dropped + 1);
}

TEST_F(Assembler, ImagesCanBeRequired) {
  FramesetAssembler a(4, true);
  for (const auto& c : cams_) a.SetCamera(c);
  for (int id = 1; id <= 3; ++id) a.AddMap(MapSample{.camera_id = id, .seq = 1, .capture_time_ns = 0,
      .camera_count = 3, .map = Map()});
  EXPECT_FALSE(a.IsComplete(1));
  for (int id = 1; id <= 3; ++id)
    a.AddImage({.camera_id = id, .seq = 1, .image = cv::Mat(12, 16, CV_8UC3, cv::Scalar(1, 2, 3))});
  ASSERT_TRUE(a.IsComplete(1));
  EXPECT_EQ(a.Take(1)->images.size(), 3u);
}


// Framesets by capture time: cameras that are not frame-locked.
constexpr int64_t kMs = 1000000;

struct Shot {
  int camera;
  uint64_t seq;
  int64_t t_ns;
};

// Each camera's shots in its own order; `period_ms` and `offset_ms` per camera.
std::vector<std::vector<Shot>> Streams(const std::vector<double>& period_ms, const std::vector<double>& offset_ms,
                                       int frames, double jitter_ms = 0, unsigned seed = 1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(-jitter_ms, jitter_ms);
  std::vector<std::vector<Shot>> out(period_ms.size());
  for (size_t c = 0; c < period_ms.size(); ++c)
    for (int i = 0; i < frames; ++i)
      out[c].push_back({int(c) + 1, uint64_t(i + 1),
                        int64_t((1000 + offset_ms[c] + i * period_ms[c] + (jitter_ms > 0 ? jitter(rng) : 0)) * kMs)});
  return out;
}

// All shots merged in the order they would arrive from several capture hosts:
// each after a random transport delay of up to 40 ms (two frame periods), each
// camera's in its own order (one reliable writer per camera).
std::vector<Shot> Interleave(const std::vector<std::vector<Shot>>& streams, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> delay_ms(0, 40);
  std::vector<std::pair<int64_t, Shot>> arrivals;
  for (const auto& stream : streams) {
    int64_t previous = 0;
    for (const Shot& s : stream) {
      previous = std::max(previous, s.t_ns + int64_t(delay_ms(rng) * kMs));
      arrivals.push_back({previous, s});
    }
  }
  std::stable_sort(arrivals.begin(), arrivals.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<Shot> out;
  for (const auto& [t, s] : arrivals) out.push_back(s);
  return out;
}

class TimedAssembler : public Assembler {
 protected:
  void Add(FramesetAssembler& a, const Shot& s, uint64_t source = 0) {
    a.AddMap(MapSample{.camera_id = s.camera, .seq = s.seq, .capture_time_ns = s.t_ns, .camera_count = 3, .map = Map(),
        .source_time_s = 0, .source_id = source});
  }
  // Feeds every shot, taking each frameset as soon as it is complete (oldest
  // first, as recon does when poses name them); returns reference seq -> skews.
  std::map<uint64_t, std::vector<int64_t>> Run(FramesetAssembler& a, const std::vector<Shot>& shots) {
    for (const auto& c : cams_) a.SetCamera(c);
    std::map<uint64_t, std::vector<int64_t>> taken;
    for (const Shot& s : shots) {
      Add(a, s);
      for (uint64_t seq = 1; seq <= 400; ++seq)
        if (a.IsComplete(seq)) taken[seq] = a.Take(seq)->skew_ns;
    }
    return taken;
  }
};

TEST_F(TimedAssembler, TheNearestSampleOfEachCameraIsChosen) {
  // 20 ms cameras; camera 2 runs 7 ms after camera 1, camera 3 6 ms before it.
  FramesetAssembler a(6);
  const auto taken = Run(a, Interleave(Streams({20, 20, 20}, {0, 7, -6}, 20), 3));
  ASSERT_GE(taken.size(), 18u);
  for (const auto& [seq, skew] : taken) {
    ASSERT_EQ(skew.size(), 3u);
    EXPECT_EQ(skew[0], 0);
    EXPECT_EQ(skew[1], 7 * kMs) << seq;   // 7 ms beats the 13 ms of the frame before
    EXPECT_EQ(skew[2], -6 * kMs) << seq;  // -6 ms beats the 14 ms of the frame after
  }
  EXPECT_EQ(a.dropped_for_skew(), 0u);
  const auto r = a.SkewReports();
  ASSERT_EQ(r.size(), 3u);
  EXPECT_NEAR(r[1].skew_ms_max, 7.0, 1e-9);
  EXPECT_NEAR(r[2].skew_ms_p50, 6.0, 1e-9);
  EXPECT_NEAR(r[0].period_ms, 20.0, 1e-9);
  EXPECT_NEAR(a.tolerance_s(), 0.010, 1e-12);  // half the slowest camera's period
}

TEST_F(TimedAssembler, TheChoiceDoesNotDependOnTheOrderOfArrival) {
  // Several nodes assemble the same traffic in different orders: they must build
  // the same framesets, or recon tiles of one frameset would disagree.
  // (A fixed tolerance: the default one is measured from recent frames, which a
  // node that started later has seen fewer of.)
  const auto streams = Streams({20, 21, 19.5}, {0, 9, -4}, 60, 2.0, 7);
  FramesetAssembler all_at_once(100);
  all_at_once.SetTolerance(0.0105);
  for (const auto& c : cams_) all_at_once.SetCamera(c);
  for (const Shot& s : Interleave(streams, 1)) Add(all_at_once, s);
  std::map<uint64_t, std::vector<int64_t>> reference;
  for (uint64_t seq = 1; seq <= 60; ++seq)
    if (all_at_once.IsComplete(seq)) reference[seq] = all_at_once.Take(seq)->skew_ns;
  ASSERT_GE(reference.size(), 40u);
  for (unsigned order = 2; order < 8; ++order) {
    FramesetAssembler a(100);
    a.SetTolerance(0.0105);
    const auto taken = Run(a, Interleave(streams, order));
    for (const auto& [seq, skew] : taken) {
      ASSERT_TRUE(reference.count(seq)) << "order " << order << " frameset " << seq;
      EXPECT_EQ(skew, reference.at(seq)) << "order " << order << " frameset " << seq;
    }
    EXPECT_EQ(taken.size(), reference.size()) << "order " << order;
  }
}

TEST_F(TimedAssembler, JitterWithinHalfAPeriodLosesNothing) {
  FramesetAssembler a(6);
  const auto taken = Run(a, Interleave(Streams({20, 20, 20}, {0, 3, -2}, 200, 3.0, 11), 5));
  // Offsets of 3 and 2 ms plus jitter of up to 3 ms on both sides: |skew| <= 9 ms
  // < the 10 ms tolerance, so every frame but the last (undecided) is taken.
  EXPECT_GE(taken.size(), 198u);
  EXPECT_EQ(a.dropped_for_skew(), 0u);
  for (const auto& r : a.SkewReports()) EXPECT_LE(r.skew_ms_max, 9.0 + 1e-9);
}

TEST_F(TimedAssembler, ACameraFivePercentSlowDriftsButStaysPartnered) {
  FramesetAssembler a(6);
  const auto taken = Run(a, Interleave(Streams({20, 21, 20}, {0, 0, 0}, 200), 9));
  // Camera 2's phase walks through every value; its nearest frame is always
  // within half of its 21 ms period, the tolerance.
  EXPECT_GE(taken.size(), 188u);  // 200 reference frames; camera 2 has 190 in the same time
  EXPECT_EQ(a.dropped_for_skew(), 0u);
  EXPECT_NEAR(a.tolerance_s(), 0.0105, 1e-9);
  EXPECT_LE(a.SkewReports()[1].skew_ms_max, 10.5 + 1e-9);
}

TEST_F(TimedAssembler, AMissingCameraStallsFramesetsUntilItReturnsAndIsCountedOnce) {
  auto streams = Streams({20, 20, 20}, {0, 1, 2}, 150);
  // Camera 3 pauses for one second: frames 40..89 never come.
  streams[2].erase(streams[2].begin() + 39, streams[2].begin() + 89);
  FramesetAssembler a(6);
  const auto taken = Run(a, Interleave(streams, 4));
  for (uint64_t seq = 41; seq <= 89; ++seq) EXPECT_FALSE(taken.count(seq)) << seq;
  EXPECT_GE(taken.size(), 97u);  // 150 - 50 missing - the last, undecided
  const auto r = a.SkewReports();
  EXPECT_EQ(r[2].pauses, 1u);
  EXPECT_EQ(r[0].pauses + r[1].pauses, 0u);
  EXPECT_GT(r[0].unpartnered + a.dropped(), 0u);
}

// A camera that pauses again and again is said once in the log and counted
// each time (a rig falling behind pauses every frame).
TEST_F(TimedAssembler, RepeatedPausesAreLoggedOnceAndCountedEach) {
  auto streams = Streams({20, 20, 20}, {0, 1, 2}, 300);
  // Camera 3 pauses for a second three times.
  for (int k = 2; k >= 0; --k) streams[2].erase(streams[2].begin() + 40 + 90 * k, streams[2].begin() + 90 + 90 * k);
  auto lines = std::make_shared<std::ostringstream>();
  auto previous = spdlog::default_logger();
  spdlog::set_default_logger(
      std::make_shared<spdlog::logger>("capture", std::make_shared<spdlog::sinks::ostream_sink_mt>(*lines)));
  FramesetAssembler a(6);
  (void)Run(a, Interleave(streams, 4));
  spdlog::set_default_logger(previous);
  EXPECT_EQ(a.SkewReports()[2].pauses, 3u);
  const std::string log = lines->str();
  size_t said = 0;
  for (size_t at = log.find("no frame for"); at != std::string::npos; at = log.find("no frame for", at + 1)) ++said;
  EXPECT_EQ(said, 1u) << log;
}

TEST_F(TimedAssembler, ARestartedCameraIsFollowed) {
  FramesetAssembler a(6);
  for (const auto& c : cams_) a.SetCamera(c);
  auto streams = Streams({20, 20, 20}, {0, 0, 0}, 60);
  // Camera 2's node restarts after frame 30: a new writer, frame numbers from 1.
  for (size_t i = 30; i < 60; ++i) streams[1][i].seq = i - 29;
  int taken = 0;
  for (size_t i = 0; i < 60; ++i)
    for (int c = 0; c < 3; ++c) {
      ASSERT_TRUE(a.AddMap(MapSample{.camera_id = c + 1, .seq = streams[c][i].seq,
          .capture_time_ns = streams[c][i].t_ns, .camera_count = 3, .map = Map(), .source_time_s = 0,
          .source_id = c == 1 && i >= 30 ? 2u : 1u}));
      if (auto f = a.TakeNewest()) ++taken;
    }
  EXPECT_EQ(taken, 60);
  EXPECT_EQ(a.SkewReports()[1].restarts, 1u);
  EXPECT_EQ(a.restarts(), 0u);  // not the reference camera: frameset ids go on
}

TEST_F(TimedAssembler, AClockOffBeyondTheToleranceIsDetectedAndCounted) {
  FramesetAssembler a(6);
  a.SetTolerance(0.005);
  // Camera 3's host clock is 8 ms ahead: its nearest frame is 8 ms (or 12 ms) off.
  const auto taken = Run(a, Interleave(Streams({20, 20, 20}, {0, 1, 8}, 40), 2));
  // Positive control: with camera 3 at 1 ms every frameset would be taken
  // (TheNearestSampleOfEachCameraIsChosen); here none is.
  EXPECT_TRUE(taken.empty());
  EXPECT_GE(a.dropped_for_skew(), 25u);  // 40 reference frames, the newest 8 still pending
  EXPECT_EQ(a.SkewReports()[2].clock_offsets, 1u);  // one episode, logged once
  EXPECT_EQ(a.SkewReports()[1].clock_offsets, 0u);
}

TEST_F(TimedAssembler, CaptureTimesThatDisagreeWithArrivalNameTheCamera) {
  // Arrival on the assembling node's clock minus the stamped capture time: a
  // camera stamped in the future, or much later than the others, has a clock off.
  // With live cameras this is the only sign: pairing by nearest time alone would
  // quietly match frames from different instants.
  for (const double camera3_delay_ms : {-25.0, 150.0, 20.0}) {
    FramesetAssembler a(6);
    for (const auto& c : cams_) a.SetCamera(c);
    const auto streams = Streams({20, 20, 20}, {0, 1, 2}, 40);
    for (size_t i = 0; i < 40; ++i)
      for (int c = 0; c < 3; ++c) {
        const Shot& s = streams[c][i];
        const double delay_ms = c == 2 ? camera3_delay_ms : 5.0 + c;
        a.AddMap(MapSample{.camera_id = s.camera, .seq = s.seq, .capture_time_ns = s.t_ns, .camera_count = 3,
            .map = Map(), .source_time_s = 0, .source_id = 0, .arrival_ns = s.t_ns + int64_t(delay_ms * kMs)});
      }
    const auto r = a.SkewReports();
    // 20 ms later than the others is transport and processing (< 50 ms): the control.
    EXPECT_EQ(r[2].clock_offsets, camera3_delay_ms == 20.0 ? 0u : 1u) << camera3_delay_ms;
    EXPECT_EQ(r[0].clock_offsets + r[1].clock_offsets, 0u);
  }
}

}  // namespace
}  // namespace hullpipe
