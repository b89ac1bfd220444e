#include "hullpipe/nodes/render_controller.h"

#include <algorithm>
#include <atomic>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "hullpipe/geometry/rigid3.h"
#include "hullpipe/nodes/render_flags.h"
#include "hullpipe/nodes/test_rig.h"

namespace hullpipe::nodes {
namespace {

struct Recorder final : RenderSink {
  struct Pose {
    NovelView view;
    uint64_t pose_seq, frame_seq;
    ViewEye eye;
    int64_t stamp_ns;
  };
  std::vector<Pose> poses;
  std::vector<std::pair<uint64_t, cv::Mat>> frames;  // frame_seq, image
  void PublishPose(const NovelView& v, uint64_t pose_seq, uint64_t frame_seq, ViewEye eye,
                   int64_t stamp_ns) override {
    poses.push_back({v, pose_seq, frame_seq, eye, stamp_ns});
  }
  std::vector<NovelView> right_views;  // the right eye's, for each stereo frame
  void WriteFrame(const cv::Mat& f, uint64_t frame_seq, uint64_t, const NovelView&, const cv::Mat&, double,
                  const RightEye* right) override {
    frames.push_back({frame_seq, f.clone()});
    if (right) right_views.push_back(right->view);
  }
  struct Published {
    cv::Mat frame;
    uint64_t pose_seq, frame_seq;
    int64_t capture_time_ns;
    ViewEye eye;
  };
  std::vector<Published> published;
  void PublishComposite(const cv::Mat& f, uint64_t pose_seq, uint64_t frame_seq, int64_t capture_time_ns,
                        ViewEye eye) override {
    published.push_back({f.clone(), pose_seq, frame_seq, capture_time_ns, eye});
  }
};

// A whole-view tile for a pose: depth `depth_m` everywhere (kNoDepth: no hull), colour `bgr`.
HullTile WholeTile(const Recorder::Pose& p, float depth_m, cv::Scalar bgr) {
  HullTile t;
  t.rect = cv::Rect(0, 0, p.view.width, p.view.height);
  t.depth = cv::Mat(t.rect.size(), CV_32FC1, cv::Scalar(depth_m));
  t.colour = cv::Mat(t.rect.size(), CV_8UC3, bgr);
  t.pose_seq = p.pose_seq;
  t.frame_seq = p.frame_seq;
  return t;
}

// Red dominates (the compositor shades colliding objects' red by the light).
bool Red(const cv::Vec3b& bgr) { return bgr[2] > 40 && bgr[2] > 3 * bgr[1] && bgr[2] > 3 * bgr[0]; }

class Render : public ::testing::Test {
 protected:
  Render() { rig_.Calibrate(assembler_); }
  RenderOptions Options() const {
    RenderOptions o;
    o.width = 64;
    o.height = 48;
    o.tiles = 1;
    o.orbit_centre = hullpipe::test::kSphereCentre;
    return o;
  }
  FakeClock clock_;
  FramesetAssembler assembler_{8, false};
  test::TinyRig rig_;
  Recorder sink_;
};

TEST_F(Render, OptionsCheckNamesTheFlag) {
  RenderOptions o;
  o.width = 0;
  EXPECT_THROW(o.Check(), std::invalid_argument);
  o = {};
  o.tiles = 0;
  try {
    o.Check();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--tiles"), std::string::npos);
  }
  o = {};
  o.up = Eigen::Vector3d::Zero();
  EXPECT_THROW(o.Check(), std::invalid_argument);
  o = {};
  o.view = RenderOptions::View::kFile;  // without a track
  EXPECT_THROW(o.Check(), std::invalid_argument);
}

TEST_F(Render, PosesFollowNewFramesetsUpToMaxInFlight) {
  RenderOptions o = Options();
  o.max_in_flight = 2;
  RenderController r(o, clock_, assembler_, sink_);
  EXPECT_EQ(r.Step(), 0);
  EXPECT_TRUE(sink_.poses.empty());  // no frameset yet
  rig_.AddFrame(assembler_, 1, clock_.WallNs());
  r.Step();
  rig_.AddFrame(assembler_, 2, clock_.WallNs());
  r.Step();
  rig_.AddFrame(assembler_, 3, clock_.WallNs());
  r.Step();
  ASSERT_EQ(sink_.poses.size(), 2u);  // frame 3 waits: two poses in flight
  EXPECT_EQ(sink_.poses[0].frame_seq, 1u);
  EXPECT_EQ(sink_.poses[1].frame_seq, 2u);
  EXPECT_EQ(r.in_flight(), 2u);
  // Pose 2's tile composites it and supersedes pose 1 (dropped); frame 3 is next.
  r.OnTile(WholeTile(sink_.poses[1], kNoDepth, {0, 0, 0}));
  EXPECT_EQ(r.Step(), 1);
  ASSERT_EQ(sink_.frames.size(), 1u);
  EXPECT_EQ(sink_.frames[0].first, 2u);
  EXPECT_EQ(r.counters().dropped(), 1u);
  r.Step();
  ASSERT_EQ(sink_.poses.size(), 3u);
  EXPECT_EQ(sink_.poses[2].frame_seq, 3u);
  // A tile for a pose that is gone is late, not an error.
  r.OnTile(WholeTile(sink_.poses[0], kNoDepth, {0, 0, 0}));
  EXPECT_EQ(r.tiles_late(), 1u);
  EXPECT_EQ(r.rejected(), 0u);
}

// Each composited frame is also published for viewers (the CompositedView
// topic): the very frame written, with its pose, frameset and capture time.
// Turned off, nothing is published while frames are still written (the
// control that the publication is the option's doing).
TEST_F(Render, EachCompositedFrameIsPublishedForViewersUnlessTurnedOff) {
  for (const bool publish : {true, false}) {
    SCOPED_TRACE(publish ? "publishing" : "not publishing");
    Recorder sink;
    RenderOptions o = Options();
    o.publish_composite = publish;
    RenderController r(o, clock_, assembler_, sink);
    const uint64_t base = publish ? 0 : 10;
    for (uint64_t f = base + 1; f <= base + 3; ++f) {
      rig_.AddFrame(assembler_, f, clock_.WallNs());
      r.Step();
      ASSERT_FALSE(sink.poses.empty());
      r.OnTile(WholeTile(sink.poses.back(), kNoDepth, {0, 0, 0}));
      EXPECT_EQ(r.Step(), 1);
      clock_.Advance(0.04);
    }
    ASSERT_EQ(sink.frames.size(), 3u);
    if (!publish) {
      EXPECT_TRUE(sink.published.empty());
      continue;
    }
    ASSERT_EQ(sink.published.size(), 3u);
    for (size_t i = 0; i < 3; ++i) {
      EXPECT_EQ(sink.published[i].pose_seq, sink.poses[i].pose_seq);
      EXPECT_EQ(sink.published[i].eye, ViewEye::kMono);
      EXPECT_EQ(sink.poses[i].eye, ViewEye::kMono);
      EXPECT_EQ(sink.published[i].frame_seq, sink.frames[i].first);
      EXPECT_GT(sink.published[i].capture_time_ns, 0);
      EXPECT_EQ(cv::norm(sink.published[i].frame, sink.frames[i].second, cv::NORM_INF), 0);
    }
  }
  RenderOptions bad = Options();
  bad.publish_max_side = 8;
  EXPECT_THROW(bad.Check(), std::invalid_argument);
  bad = Options();
  bad.publish_jpeg_quality = 101;
  EXPECT_THROW(bad.Check(), std::invalid_argument);
}

TEST_F(Render, APoseWhoseTilesDoNotComeIsDroppedAfterTheTileTimeout) {
  RenderOptions o = Options();
  o.tiles = 2;
  o.tile_timeout = 1.0;
  RenderController r(o, clock_, assembler_, sink_);
  rig_.AddFrame(assembler_, 1, clock_.WallNs());
  r.Step();
  ASSERT_EQ(sink_.poses.size(), 1u);
  HullTile half = WholeTile(sink_.poses[0], kNoDepth, {0, 0, 0});
  half.rect.height = 24;
  half.depth = half.depth(cv::Rect(0, 0, 64, 24)).clone();
  half.colour = half.colour(cv::Rect(0, 0, 64, 24)).clone();
  r.OnTile(half);  // one of two tiles
  clock_.Advance(0.9);
  r.Step();
  EXPECT_EQ(r.in_flight(), 1u);
  clock_.Advance(0.2);
  r.Step();
  EXPECT_EQ(r.in_flight(), 0u);
  EXPECT_EQ(r.counters().dropped(), 1u);
  EXPECT_TRUE(sink_.frames.empty());
}

// Recon nodes that need longer than the tile time-out (a rig of many cameras
// on a small machine): the first pose is given up on, its tile comes 1.5 s
// after the pose, and the time-out becomes twice that, so the next pose whose
// tile takes as long is composited (before, every pose was dropped and render
// composited nothing). The late tile itself composites its pose, which nothing
// newer was composited before.
TEST_F(Render, TilesThatComeLateRaiseTheTileTimeout) {
  RenderOptions o = Options();
  o.tiles = 1;
  o.tile_timeout = 1.0;
  o.max_in_flight = 1;
  RenderController r(o, clock_, assembler_, sink_);
  rig_.AddFrame(assembler_, 1, clock_.WallNs());
  r.Step();
  ASSERT_EQ(sink_.poses.size(), 1u);
  clock_.Advance(1.1);
  r.Step();
  EXPECT_EQ(r.counters().dropped(), 1u);  // given up at 1 s
  clock_.Advance(0.4);
  r.OnTile(WholeTile(sink_.poses[0], 2.0f, {10, 20, 30}));  // 1.5 s after its pose
  EXPECT_EQ(r.tiles_late(), 1u);
  EXPECT_NEAR(r.tile_timeout(), 3.0, 1e-9);
  EXPECT_EQ(r.Step(), 1) << "the given-up pose is composited when its tile comes";
  ASSERT_EQ(sink_.frames.size(), 1u);
  EXPECT_EQ(sink_.frames[0].first, 1u);
  EXPECT_EQ(r.late_composited(), 1u);
  EXPECT_EQ(r.counters().dropped(), 0u);
  rig_.AddFrame(assembler_, 2, clock_.WallNs());
  r.Step();
  ASSERT_EQ(sink_.poses.size(), 2u);
  clock_.Advance(1.5);
  r.Step();
  EXPECT_EQ(r.in_flight(), 1u) << "still waiting at 1.5 s";
  r.OnTile(WholeTile(sink_.poses[1], 2.0f, {10, 20, 30}));
  EXPECT_EQ(r.Step(), 1);
  ASSERT_EQ(sink_.frames.size(), 2u);
  EXPECT_EQ(r.late_composited(), 1u);
  // A late tile of a pose never given up on (another run's, say) raises nothing.
  HullTile stray = WholeTile(sink_.poses[1], 2.0f, {10, 20, 30});
  stray.pose_seq = 999;
  clock_.Advance(10);
  r.OnTile(stray);
  EXPECT_NEAR(r.tile_timeout(), 3.0, 1e-9);
}

// A given-up pose is composited late only while nothing newer was: once a
// newer frame is out, its late tiles are dropped (latest wins). And at the
// input's end render waits for a given-up pose's tiles (a first frameset of
// many cameras that takes seconds) rather than ending with nothing.
TEST_F(Render, AGivenUpPoseIsCompositedLateOnlyIfNothingNewerWas) {
  RenderOptions o = Options();
  o.tile_timeout = 1.0;
  o.max_in_flight = 2;
  RenderController r(o, clock_, assembler_, sink_);
  rig_.AddFrame(assembler_, 1, clock_.WallNs());
  r.Step();
  rig_.AddFrame(assembler_, 2, clock_.WallNs());
  r.Step();
  ASSERT_EQ(sink_.poses.size(), 2u);
  clock_.Advance(1.1);
  r.Step();
  EXPECT_EQ(r.counters().dropped(), 2u);  // both given up
  r.OnTile(WholeTile(sink_.poses[1], 2.0f, {10, 20, 30}));  // frame 2 first
  EXPECT_EQ(r.Step(), 1);
  r.OnTile(WholeTile(sink_.poses[0], 2.0f, {10, 20, 30}));  // then frame 1: older, stays dropped
  EXPECT_EQ(r.Step(), 0);
  ASSERT_EQ(sink_.frames.size(), 1u);
  EXPECT_EQ(sink_.frames[0].first, 2u);
  EXPECT_EQ(r.late_composited(), 1u);
  EXPECT_EQ(r.counters().dropped(), 1u);
}

TEST_F(Render, AtTheInputsEndAGivenUpPoseIsWaitedFor) {
  for (const bool tile_comes : {true, false}) {
    SCOPED_TRACE(tile_comes ? "its tile comes at 4 s" : "its tile never comes");
    Recorder sink;
    FramesetAssembler assembler{8, false};
    rig_.Calibrate(assembler);
    RenderOptions o = Options();
    o.tile_timeout = 1.0;
    RenderController r(o, clock_, assembler, sink);
    rig_.AddFrame(assembler, 1, clock_.WallNs());
    r.Step();
    ASSERT_EQ(sink.poses.size(), 1u);
    NodeStatsSample cap;
    cap.name = "capture";
    cap.final_report = true;
    r.OnNodeStats(cap);  // the input ended
    const double t0 = clock_.Now();
    while (!r.done() && clock_.Now() - t0 < 20) {
      clock_.Advance(0.1);
      if (tile_comes && clock_.Now() - t0 > 4 && sink.frames.empty())
        r.OnTile(WholeTile(sink.poses[0], 2.0f, {10, 20, 30}));
      r.Step();
    }
    EXPECT_TRUE(r.done());
    if (tile_comes) {
      ASSERT_EQ(sink.frames.size(), 1u);
      EXPECT_LT(clock_.Now() - t0, 5.0);
    } else {
      EXPECT_TRUE(sink.frames.empty());
      // Waited for it up to kLateWaitS after the pose, then ended.
      EXPECT_GT(clock_.Now() - t0, RenderController::kLateWaitS - 1);
      EXPECT_LT(clock_.Now() - t0, RenderController::kLateWaitS + 2);
    }
  }
}

TEST_F(Render, ATileOutsideTheViewIsRejectedAndNotComposited) {
  RenderController r(Options(), clock_, assembler_, sink_);
  rig_.AddFrame(assembler_, 1, clock_.WallNs());
  r.Step();
  HullTile t = WholeTile(sink_.poses[0], kNoDepth, {0, 0, 0});
  t.rect.x = 10;  // 10 + 64 > 64
  r.OnTile(t);
  EXPECT_EQ(r.rejected(), 1u);
  EXPECT_EQ(r.Step(), 0);
  // The node's rejected count: its own, the caller's undecodable samples and
  // the assembler's.
  r.SetMalformedInput(2);
  r.Step();
  EXPECT_EQ(r.counters().rejected(), 3u);
}

// A ball's state: object id, frameset, centre (world), colliding; 0.2 m radius.
VirtualObjectSample Ball(uint32_t id, uint64_t frame_seq, const Eigen::Vector3d& centre, bool colliding) {
  VirtualObjectSample s;
  s.object_id = id;
  s.frame_seq = frame_seq;
  s.radius = 0.2;
  s.position = centre;
  s.colliding = colliding;
  return s;
}

TEST_F(Render, CompositesWithTheDepthTestAndDrawsCollidingObjectsRed) {
  RenderOptions o = Options();
  o.max_in_flight = 1;
  RenderController r(o, clock_, assembler_, sink_);
  rig_.AddFrame(assembler_, 1, clock_.WallNs());
  r.Step();
  const Recorder::Pose& p = sink_.poses[0];
  // A colliding ball 2 m in front of the eye, on its optical axis.
  const Eigen::Vector3d ahead = p.view.world_from_eye * Eigen::Vector3d(0, 0, 2.0);
  r.OnObjectState(Ball(7, 1, ahead, true));
  // No hull in the view: the ball shows, red.
  r.OnTile(WholeTile(p, kNoDepth, {0, 0, 0}));
  ASSERT_EQ(r.Step(), 1);
  const cv::Vec3b ball = sink_.frames[0].second.at<cv::Vec3b>(24, 32);
  EXPECT_TRUE(Red(ball)) << ball;
  // Next frame: a green hull 1 m in front hides the ball; at 3 m it is behind it.
  for (float hull_m : {1.0f, 3.0f}) {
    const uint64_t seq = hull_m < 2 ? 2 : 3;
    rig_.AddFrame(assembler_, seq, clock_.WallNs());
    r.Step();
    r.OnObjectState(Ball(7, seq, ahead, true));  // sim's step of this frameset
    r.OnTile(WholeTile(sink_.poses.back(), hull_m, {0, 200, 0}));
    ASSERT_EQ(r.Step(), 1);
    const cv::Vec3b c = sink_.frames.back().second.at<cv::Vec3b>(24, 32);
    if (hull_m < 2)
      EXPECT_EQ(c, cv::Vec3b(0, 200, 0)) << "the hull in front of the ball";
    else
      EXPECT_TRUE(Red(c)) << "the ball in front of the hull: " << c;
  }
  // The same ball not colliding is not drawn red.
  rig_.AddFrame(assembler_, 4, clock_.WallNs());
  r.Step();
  r.OnObjectState(Ball(7, 4, ahead, false));
  r.OnTile(WholeTile(sink_.poses.back(), kNoDepth, {0, 0, 0}));
  ASSERT_EQ(r.Step(), 1);
  const cv::Vec3b calm = sink_.frames.back().second.at<cv::Vec3b>(24, 32);
  EXPECT_FALSE(Red(calm)) << calm;
  EXPECT_NE(calm, cv::Vec3b(0, 0, 0)) << "the ball is drawn";
  // A box state (SHAPE_BOX) in the ball's place, turned, colliding: drawn red
  // from its state alone, where the ball was.
  rig_.AddFrame(assembler_, 5, clock_.WallNs());
  r.Step();
  VirtualObjectSample box = Ball(8, 5, ahead, true);
  box.shape = VirtualObjectSample::Shape::kBox;
  box.half_extents = Eigen::Vector3d(0.2, 0.1, 0.3);
  box.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d(1, 1, 0).normalized()));
  r.OnObjectState(Ball(7, 5, ahead + Eigen::Vector3d(0, 0, 100), false));  // the ball gone far away
  r.OnObjectState(box);
  r.OnTile(WholeTile(sink_.poses.back(), kNoDepth, {0, 0, 0}));
  ASSERT_EQ(r.Step(), 1);
  EXPECT_TRUE(Red(sink_.frames.back().second.at<cv::Vec3b>(24, 32)))
      << sink_.frames.back().second.at<cv::Vec3b>(24, 32);
}

// Once a pose's tiles are in, render waits briefly for the simulation's step of
// that frameset, so a ball is drawn where that frame put it, not a frame late
// (a lab run and a one-machine run composite the same images); past
// sim_wait it draws the newest state before. No simulation: no wait.
TEST_F(Render, WaitsBrieflyForTheSimulationsStepOfTheFrameset) {
  RenderOptions o = Options();
  o.max_in_flight = 1;
  o.sim_wait = 0.1;
  RenderController r(o, clock_, assembler_, sink_);
  rig_.AddFrame(assembler_, 1, clock_.WallNs());
  r.Step();
  const Recorder::Pose& p = sink_.poses[0];
  const Eigen::Vector3d ahead = p.view.world_from_eye * Eigen::Vector3d(0, 0, 2.0);
  const Eigen::Vector3d aside = p.view.world_from_eye * Eigen::Vector3d(0.6, 0, 2.0);
  r.OnObjectState(Ball(7, 1, aside, true));
  r.OnTile(WholeTile(p, kNoDepth, {0, 0, 0}));
  ASSERT_EQ(r.Step(), 1);  // its state was in
  rig_.AddFrame(assembler_, 2, clock_.WallNs());
  r.Step();
  r.OnTile(WholeTile(sink_.poses.back(), kNoDepth, {0, 0, 0}));
  EXPECT_EQ(r.Step(), 0) << "composited before the simulation's step of frame 2";
  r.OnObjectState(Ball(7, 2, ahead, true));  // frame 2's step: the ball moved to the centre
  ASSERT_EQ(r.Step(), 1);
  EXPECT_TRUE(Red(sink_.frames.back().second.at<cv::Vec3b>(24, 32))) << "frame 2's ball, where frame 2 put it";
  // Frame 3's step never comes: after sim_wait, frame 2's state is drawn.
  rig_.AddFrame(assembler_, 3, clock_.WallNs());
  r.Step();
  r.OnTile(WholeTile(sink_.poses.back(), kNoDepth, {0, 0, 0}));
  EXPECT_EQ(r.Step(), 0);
  clock_.Advance(0.11);
  ASSERT_EQ(r.Step(), 1);
  EXPECT_TRUE(Red(sink_.frames.back().second.at<cv::Vec3b>(24, 32)));
  // Control: with no simulation publishing, a pose is composited at once.
  RenderController plain(o, clock_, assembler_, sink_);
  rig_.AddFrame(assembler_, 4, clock_.WallNs());
  plain.Step();
  plain.OnTile(WholeTile(sink_.poses.back(), kNoDepth, {0, 0, 0}));
  EXPECT_EQ(plain.Step(), 1);
}

TEST_F(Render, ASilentReconIsNoticedAndItsReturnLogged) {
  RenderOptions o = Options();
  o.tiles = 2;  // recon0 and recon1
  RenderController r(o, clock_, assembler_, sink_);
  NodeStatsSample s;
  s.name = "recon1";
  r.OnNodeStats(s);
  r.Step();
  clock_.Advance(0.9);
  r.Step();
  EXPECT_TRUE(r.recon_liveness().outages().empty());
  clock_.Advance(0.2);  // 1.1 s silent
  r.Step();
  EXPECT_EQ(r.recon_liveness().outages().at("recon1"), 1);
  r.OnNodeStats(s);
  r.Step();
  clock_.Advance(0.5);
  r.Step();
  EXPECT_EQ(r.recon_liveness().outages().at("recon1"), 1);
  EXPECT_EQ(r.StatsJson()["recon_outages"]["recon1"], 1);
}

// A head-mounted display (--stereo): each frameset's head pose gives two
// ViewPoses, the eyes ipd apart along the head's x axis with their own
// off-axis projections (stereo_views.h); the frame is composited when both
// eyes' tiles are in, written side by side (left, right), and each eye's
// composite published with its own pose. The views written carry both eyes.
TEST_F(Render, StereoAsksForBothEyesAndCompositesThemSideBySide) {
  RenderOptions o = Options();
  o.stereo = StereoOptions{};
  o.stereo->ipd_m = 0.07;
  RenderController r(o, clock_, assembler_, sink_);
  rig_.AddFrame(assembler_, 1, clock_.WallNs());
  r.Step();
  ASSERT_EQ(sink_.poses.size(), 2u) << "one pose per eye";
  const auto& left = sink_.poses[0];
  const auto& right = sink_.poses[1];
  EXPECT_EQ(left.frame_seq, 1u);
  EXPECT_EQ(right.frame_seq, 1u);
  EXPECT_EQ(right.pose_seq, left.pose_seq + 1);
  EXPECT_EQ(left.eye, ViewEye::kLeft) << "each pose names its eye, for viewers downstream";
  EXPECT_EQ(right.eye, ViewEye::kRight);
  // The eyes: the head's orbit pose, ipd apart along its x axis, parallel.
  const Rigid3d head = r.orbit().WorldFromEye(0.0);
  StereoOptions so = *o.stereo;
  so.width = o.width, so.height = o.height;
  const StereoViews want = MakeStereoViews(head, so);
  for (int k = 0; k < 2; ++k) {
    const NovelView& got = sink_.poses[size_t(k)].view;
    EXPECT_EQ(got.width, 64);
    EXPECT_NEAR((got.world_from_eye.translation - want.eye[size_t(k)].world_from_eye.translation).norm(), 0, 1e-12);
    EXPECT_NEAR(got.cx, want.eye[size_t(k)].cx, 1e-12);
  }
  EXPECT_NEAR((right.view.world_from_eye.translation - left.view.world_from_eye.translation).norm(), 0.07, 1e-12);
  EXPECT_NEAR((right.view.world_from_eye.translation - left.view.world_from_eye.translation)
                  .dot(head.rotation.col(0)),
              0.07, 1e-12)
      << "the right eye along the head's +x";
  EXPECT_GT(left.view.cx, right.view.cx) << "asymmetric frusta, mirrored: each eye's principal point off centre";
  // One eye's tile alone composites nothing.
  r.OnTile(WholeTile(left, 1.0f, {0, 0, 200}));
  EXPECT_EQ(r.Step(), 0);
  EXPECT_EQ(r.in_flight(), 1u);
  r.OnTile(WholeTile(right, 1.0f, {200, 0, 0}));
  ASSERT_EQ(r.Step(), 1);
  ASSERT_EQ(sink_.frames.size(), 1u);
  const cv::Mat& frame = sink_.frames[0].second;
  ASSERT_EQ(frame.size(), cv::Size(128, 48)) << "the two eyes side by side";
  EXPECT_EQ(frame.at<cv::Vec3b>(24, 32), cv::Vec3b(0, 0, 200)) << "left eye's tile, left";
  EXPECT_EQ(frame.at<cv::Vec3b>(24, 96), cv::Vec3b(200, 0, 0)) << "right eye's tile, right";
  ASSERT_EQ(sink_.right_views.size(), 1u);
  EXPECT_EQ(sink_.right_views[0].world_from_eye.translation, right.view.world_from_eye.translation);
  ASSERT_EQ(sink_.published.size(), 2u) << "each eye's composite on its own";
  EXPECT_EQ(sink_.published[0].pose_seq, left.pose_seq);
  EXPECT_EQ(sink_.published[1].pose_seq, right.pose_seq);
  EXPECT_EQ(sink_.published[0].eye, ViewEye::kLeft);
  EXPECT_EQ(sink_.published[1].eye, ViewEye::kRight);
  EXPECT_EQ(sink_.published[0].frame.size(), cv::Size(64, 48));
  EXPECT_EQ(sink_.published[1].frame.at<cv::Vec3b>(24, 32), cv::Vec3b(200, 0, 0));
  EXPECT_EQ(r.counters().frames_out(), 1u) << "one frame, two eyes";
  // A late tile for a right eye whose pose is gone is late, not a new frame.
  r.OnTile(WholeTile(right, 1.0f, {200, 0, 0}));
  EXPECT_EQ(r.tiles_late(), 1u);
  // Bad settings name their flag.
  RenderOptions bad = Options();
  bad.view = RenderOptions::View::kEyes;  // without a log
  EXPECT_THROW(bad.Check(), std::invalid_argument);
  bad = Options();
  bad.stereo = StereoOptions{};
  bad.stereo->ipd_m = 0.2;
  try {
    bad.Check();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--ipd"), std::string::npos) << e.what();
  }
}

// --view eyes: each eye's pose and field of view as an HMD runtime reported them
// (an xrLocateViews log, scenes/eye_views_example.csv), at the frameset's time.
TEST_F(Render, TheEyesComeFromAnHmdRuntimesLog) {
  RenderOptions o = Options();
  o.view = RenderOptions::View::kEyes;
  o.eye_track = LoadStereoViewTrack(std::string(HULLPIPE_SOURCE_DIR) + "/scenes/eye_views_example.csv");
  o.stereo = StereoOptions{};
  RenderController r(o, clock_, assembler_, sink_);
  rig_.AddFrame(assembler_, 1, clock_.WallNs());
  r.Step();
  ASSERT_EQ(sink_.poses.size(), 2u);
  for (const Eye e : {Eye::kLeft, Eye::kRight}) {
    const NovelView want = o.eye_track->At(0.0, e, o.width, o.height);
    const NovelView& got = sink_.poses[size_t(e)].view;
    EXPECT_LT((got.world_from_eye.translation - want.world_from_eye.translation).norm(), 1e-12);
    EXPECT_LT((got.world_from_eye.rotation - want.world_from_eye.rotation).norm(), 1e-12);
    EXPECT_EQ(got.cx, want.cx);
  }
  EXPECT_NEAR((sink_.poses[1].view.world_from_eye.translation - sink_.poses[0].view.world_from_eye.translation).norm(),
              0.064, 1e-5)
      << "the log's eyes, 64 mm apart";
}

// --view eyes-topic: an HMD runtime's client publishes both views live
// (EyeViews); until the first comes the orbit's eyes are drawn, then each eye
// is the newest sample's pose and off-axis projection, and the frame's
// tracker_to_eye runs from the sample's stamp.
TEST_F(Render, TheEyesFollowAnHmdRuntimesLiveViews) {
  RenderOptions o = Options();
  o.view = RenderOptions::View::kEyesTopic;
  o.stereo = StereoOptions{};
  o.max_in_flight = 1;
  RenderController r(o, clock_, assembler_, sink_);
  auto frame = [&](uint64_t seq) {
    rig_.AddFrame(assembler_, seq, clock_.WallNs());
    r.Step();
    EXPECT_EQ(sink_.poses.size() % 2, 0u);
    const auto left = sink_.poses[sink_.poses.size() - 2], right = sink_.poses.back();
    EXPECT_EQ(left.eye, ViewEye::kLeft);
    EXPECT_EQ(right.eye, ViewEye::kRight);
    clock_.Advance(0.005);
    r.OnTile(WholeTile(left, kNoDepth, {0, 0, 0}));
    r.OnTile(WholeTile(right, kNoDepth, {0, 0, 0}));
    EXPECT_EQ(r.Step(), 1);
    return std::make_pair(left.view, right.view);
  };
  StereoOptions so;
  so.width = o.width, so.height = o.height;
  const auto [l0, r0] = frame(1);
  EXPECT_LT(
      (l0.world_from_eye.translation - MakeStereoViews(r.orbit().WorldFromEye(0), so).eye[0].world_from_eye.translation)
          .norm(),
      1e-12)
      << "the orbit's eyes before any sample";
  EXPECT_FALSE(r.counters().stages().count("tracker_to_eye"));
  EyeViewsSample v;
  v.stamp_ns = clock_.WallNs() - 20'000'000;  // the runtime's views, 20 ms old
  v.world_from_eye[0] = LookAt(Eigen::Vector3d(1.0, 2, -1.5), hullpipe::test::kSphereCentre, Eigen::Vector3d(0, 0, -1));
  v.world_from_eye[1] =
      LookAt(Eigen::Vector3d(1.07, 2, -1.5), hullpipe::test::kSphereCentre, Eigen::Vector3d(0, 0, -1));
  v.fov = {EyeFov{-0.7, 0.5, 0.6, -0.6}, EyeFov{-0.5, 0.7, 0.6, -0.6}};
  r.OnEyeViews(v);
  const auto [l1, r1] = frame(2);
  for (size_t k = 0; k < 2; ++k) {
    const NovelView want = EyeView(v.fov[k], o.width, o.height, v.world_from_eye[k]);
    const NovelView& got = k == 0 ? l1 : r1;
    EXPECT_LT((got.world_from_eye.translation - want.world_from_eye.translation).norm(), 1e-12) << k;
    EXPECT_LT((got.world_from_eye.rotation - want.world_from_eye.rotation).norm(), 1e-12) << k;
    EXPECT_EQ(got.cx, want.cx) << k;
    EXPECT_EQ(got.fy, want.fy) << k;
  }
  // Each eye's ViewPose carries the runtime's stamp of the views it was drawn
  // from (the client shows only poses of views it sent); the orbit's, none.
  EXPECT_EQ(sink_.poses[sink_.poses.size() - 2].stamp_ns, v.stamp_ns);
  EXPECT_EQ(sink_.poses.back().stamp_ns, v.stamp_ns);
  EXPECT_EQ(sink_.poses[0].stamp_ns, 0);
  ASSERT_TRUE(r.counters().stages().count("tracker_to_eye"));
  EXPECT_NEAR(r.counters().stages().at("tracker_to_eye").Percentile(50), 25.0, 1e-3);
}

// Replaying a whole recording into a live run mixed the recorded tiles and
// NodeStats with the live ones (63 of 426 frames composited, the recorded rows
// shown as live). Now tiles and reports of another run are ignored, counted in
// stats.json and the table; this run's (and a report without a run id, from a
// node started by hand) are taken: the controls.
TEST_F(Render, TilesAndReportsOfAnotherRunAreIgnoredAndCounted) {
  RenderOptions o = Options();
  o.run_id = 0xa;
  RenderController r(o, clock_, assembler_, sink_);
  rig_.AddFrame(assembler_, 1, clock_.WallNs());
  r.Step();
  ASSERT_EQ(sink_.poses.size(), 1u);
  HullTile foreign = WholeTile(sink_.poses[0], 1.0f, {0, 200, 0});
  foreign.run_id = 0xb;
  r.OnTile(foreign);
  HullTile unset = WholeTile(sink_.poses[0], 1.0f, {0, 200, 0});
  r.OnTile(unset);  // render's own poses always carry its id: a tile without one is not its own
  EXPECT_EQ(r.Step(), 0) << "no tile of this run yet";
  HullTile own = WholeTile(sink_.poses[0], 1.0f, {0, 0, 200});
  own.run_id = 0xa;
  r.OnTile(own);
  ASSERT_EQ(r.Step(), 1);
  EXPECT_EQ(sink_.frames[0].second.at<cv::Vec3b>(24, 32), cv::Vec3b(0, 0, 200)) << "this run's tile";

  NodeStatsSample recorded;
  recorded.name = "capture";
  recorded.run_id = 0xb;
  recorded.final_report = true;  // a recorded capture's end must not end this run
  r.OnNodeStats(recorded);
  NodeStatsSample live;
  live.name = "sim";
  live.run_id = 0xa;
  r.OnNodeStats(live);
  NodeStatsSample by_hand;
  by_hand.name = "recon0";
  r.OnNodeStats(by_hand);
  clock_.Advance(1.0);
  r.Step();
  EXPECT_FALSE(r.done()) << "the other run's capture ended, not this one's";
  const auto j = r.StatsJson();
  EXPECT_EQ(j["run_id"], "000000000000000a");
  EXPECT_EQ(j["ignored_from_other_runs"]["HullView"], 2);
  EXPECT_EQ(j["ignored_from_other_runs"]["NodeStats"], 1);
  EXPECT_FALSE(j["nodes"].contains("capture")) << j.dump();
  EXPECT_TRUE(j["nodes"].contains("sim"));
  EXPECT_TRUE(j["nodes"].contains("recon0"));
  EXPECT_NE(r.Table().find("ignored 2 HullView sample(s) of other runs (this run is 000000000000000a)"),
            std::string::npos)
      << r.Table();
}

// A peer flooding NodeStats under distinct names grew render to 594 MB and its
// stats.json to 0.5 GB. The names kept are bounded; the rest are counted, and
// a node known before the flood goes on being reported (the control).
TEST_F(Render, AFloodOfNodeNamesIsBoundedAndCounted) {
  RenderController r(Options(), clock_, assembler_, sink_);
  NodeStatsSample sim;
  sim.name = "sim";
  sim.frames_in = 1;
  r.OnNodeStats(sim);
  for (int i = 0; i < 10000; ++i) {
    NodeStatsSample s;
    s.name = "recon_flood_" + std::to_string(i);
    r.OnNodeStats(s);
  }
  sim.frames_in = 7;
  r.OnNodeStats(sim);
  const auto j = r.StatsJson();
  EXPECT_EQ(j["nodes"].size(), RenderController::kMaxNodes + 1) << "and render itself";
  EXPECT_EQ(r.node_stats_over_limit(), 10001u - RenderController::kMaxNodes);
  EXPECT_EQ(j["node_stats_over_limit"], 10001u - RenderController::kMaxNodes);
  EXPECT_EQ(j["nodes"]["sim"]["frames_in"], 7) << "a known node is still reported";
  EXPECT_LT(j.dump().size(), 1u << 20);
  clock_.Advance(2.0);
  r.Step();
  EXPECT_TRUE(r.recon_liveness().outages().empty()) << "no flood name is a recon of this run";
}

// Stopping, render waits only for peers that have not yet sent their final
// report (its own reports, read back from the domain, do not count).
TEST_F(Render, AwaitsTheFinalReportsOfThePeersHeardFrom) {
  RenderController r(Options(), clock_, assembler_, sink_);
  EXPECT_FALSE(r.AwaitingFinalReports()) << "no peer heard from";
  NodeStatsSample own;
  own.name = "render";
  r.OnNodeStats(own);
  EXPECT_FALSE(r.AwaitingFinalReports());
  NodeStatsSample sim, recon;
  sim.name = "sim";
  recon.name = "recon0";
  r.OnNodeStats(sim);
  r.OnNodeStats(recon);
  EXPECT_TRUE(r.AwaitingFinalReports());
  sim.final_report = true;
  r.OnNodeStats(sim);
  EXPECT_TRUE(r.AwaitingFinalReports()) << "recon0's is still to come";
  recon.final_report = true;
  r.OnNodeStats(recon);
  EXPECT_FALSE(r.AwaitingFinalReports());
}

TEST_F(Render, EndsWhenCaptureReportsItsEndAndEverythingIsComposited) {
  RenderOptions o = Options();
  o.tile_timeout = 10;  // the pose stays in flight while the clock moves
  RenderController r(o, clock_, assembler_, sink_);
  rig_.AddFrame(assembler_, 1, clock_.WallNs());
  r.Step();
  NodeStatsSample cap;
  cap.name = "capture";
  cap.final_report = true;
  clock_.Advance(1.0);
  r.Step();
  EXPECT_FALSE(r.done()) << "capture has not said it ended";
  r.OnNodeStats(cap);
  clock_.Advance(1.0);
  r.Step();
  EXPECT_FALSE(r.done()) << "a pose is still in flight";
  r.OnTile(WholeTile(sink_.poses[0], kNoDepth, {0, 0, 0}));
  r.Step();
  EXPECT_TRUE(r.done()) << "capture ended 1 s ago and its last frameset is composited";
}

// One capture node per camera: camera 2's node ended after frame 10 while
// camera 1's went on to 60; each said "the end of my input" with exit 0.
// render, which sees both, names camera 2 once the input has ended (not before:
// live cameras lag by their latency).
TEST_F(Render, ACameraWhoseInputEndedEarlyIsNamedOnceTheInputEnded) {
  RenderOptions o = Options();
  RenderController r(o, clock_, assembler_, sink_);
  const int64_t t0 = clock_.WallNs();
  for (uint64_t f = 1; f <= 60; ++f) {
    const auto& v = rig_.views[0];
    assembler_.AddMap(MapSample{.camera_id = v.camera.id, .seq = f, .capture_time_ns = t0 + int64_t(f) * 40'000'000,
        .camera_count = 2, .map = v.map.clone()});
    if (f <= 10) {
      const auto& w = rig_.views[1];
      assembler_.AddMap(MapSample{.camera_id = w.camera.id, .seq = f, .capture_time_ns = t0 + int64_t(f) * 40'000'000,
          .camera_count = 2, .map = w.map.clone()});
    }
  }
  r.Step();
  EXPECT_EQ(r.IncompleteInput(), "") << "the input has not ended yet";
  NodeStatsSample cap;
  cap.name = "capture";
  cap.final_report = true;
  r.OnNodeStats(cap);
  const std::string line = r.IncompleteInput();
  EXPECT_NE(line.find("the input ended early (exit 3): camera(s) " + std::to_string(rig_.views[1].camera.id) +
                      " ended before the others"),
            std::string::npos)
      << line;
  EXPECT_NE(line.find("10 frames, ended 2.00 s of capture time before the last"), std::string::npos) << line;
  EXPECT_EQ(r.StatsJson()["cameras_ended_early"].size(), 1u);
}

TEST_F(Render, NoCameraEndedEarlyWhenAllEndTogether) {
  RenderController r(Options(), clock_, assembler_, sink_);
  for (uint64_t f = 1; f <= 60; ++f) rig_.AddFrame(assembler_, f, clock_.WallNs() + int64_t(f) * 40'000'000);
  NodeStatsSample cap;
  cap.name = "capture";
  cap.final_report = true;
  r.OnNodeStats(cap);
  EXPECT_EQ(r.IncompleteInput(), "");
  EXPECT_TRUE(r.StatsJson()["cameras_ended_early"].empty());
}

TEST_F(Render, EndsWhenNoFramesetCameForTheIdleTimeout) {
  RenderOptions o = Options();
  o.idle_timeout = 2.0;
  RenderController r(o, clock_, assembler_, sink_);
  clock_.Advance(10);
  r.Step();
  EXPECT_FALSE(r.done()) << "never idle before the first frameset";
  rig_.AddFrame(assembler_, 1, clock_.WallNs());
  r.Step();
  r.OnTile(WholeTile(sink_.poses[0], kNoDepth, {0, 0, 0}));
  r.Step();
  clock_.Advance(1.9);
  r.Step();
  EXPECT_FALSE(r.done());
  clock_.Advance(0.2);
  r.Step();
  EXPECT_TRUE(r.done());
}

TEST_F(Render, StopsAfterTheRequestedFrame) {
  RenderOptions o = Options();
  o.max_frames = 2;
  RenderController r(o, clock_, assembler_, sink_);
  for (uint64_t seq : {1, 2}) {
    rig_.AddFrame(assembler_, seq, clock_.WallNs());
    r.Step();
    r.OnTile(WholeTile(sink_.poses.back(), kNoDepth, {0, 0, 0}));
    r.Step();
    EXPECT_EQ(r.done(), seq == 2);
  }
}

// SIGINT mid-composite: the composite is abandoned (Composite polls the flag
// per row) and the frame is not written; with the flag clear the same pose
// composites (positive control).
TEST_F(Render, AStopRequestAbandonsTheCompositeAndWritesNothing) {
  RenderOptions o = Options();
  o.max_in_flight = 1;
  RenderController r(o, clock_, assembler_, sink_);
  std::atomic<bool> stop{true};
  r.set_stop(&stop);
  rig_.AddFrame(assembler_, 1, clock_.WallNs());
  r.Step();
  r.OnTile(WholeTile(sink_.poses.back(), 1.0f, {0, 200, 0}));
  EXPECT_THROW(r.Step(), Interrupted);
  EXPECT_TRUE(sink_.frames.empty());
  EXPECT_EQ(r.counters().frames_out(), 0u);
  stop = false;
  EXPECT_EQ(r.Step(), 1);
  ASSERT_EQ(sink_.frames.size(), 1u);
  EXPECT_EQ(sink_.frames[0].second.at<cv::Vec3b>(24, 32), cv::Vec3b(0, 200, 0));
}

TEST_F(Render, TheViewFollowsTheOrbitThenTheTrackersNewestPose) {
  RenderOptions o = Options();
  o.view = RenderOptions::View::kTopic;
  o.max_in_flight = 1;
  RenderController r(o, clock_, assembler_, sink_);
  auto next_pose = [&](uint64_t seq) {
    rig_.AddFrame(assembler_, seq, clock_.WallNs());
    r.Step();
    const Recorder::Pose p = sink_.poses.back();
    r.OnTile(WholeTile(p, kNoDepth, {0, 0, 0}));
    r.Step();
    return p.view.world_from_eye;
  };
  // Before any HeadPose: the orbit at the frame's path time (frame 1: t = 0).
  const Rigid3d first = next_pose(1);
  const Rigid3d orbit0 = r.orbit().WorldFromEye(0);
  EXPECT_LT((first.translation - orbit0.translation).norm(), 1e-12);
  // Then the tracker's newest pose, whatever the path time.
  Rigid3d tracked = LookAt(Eigen::Vector3d(1, 2, -3), hullpipe::test::kSphereCentre, Eigen::Vector3d(0, 0, -1));
  r.OnHeadPose(LookAt(Eigen::Vector3d(5, 5, -5), hullpipe::test::kSphereCentre, Eigen::Vector3d(0, 0, -1)));
  r.OnHeadPose(tracked, /*stamp_ns=*/clock_.WallNs() - 15'000'000);  // measured 15 ms ago
  EXPECT_FALSE(r.counters().stages().count("tracker_to_eye")) << "no frame from a tracker's pose yet (the control)";
  rig_.AddFrame(assembler_, 2, clock_.WallNs());
  r.Step();
  clock_.Advance(0.010);  // its tile comes 10 ms later
  const Recorder::Pose p = sink_.poses.back();
  r.OnTile(WholeTile(p, kNoDepth, {0, 0, 0}));
  r.Step();
  const Rigid3d second = p.view.world_from_eye;
  EXPECT_EQ(p.stamp_ns, clock_.WallNs() - 25'000'000) << "the pose is stamped with the tracker's sample";
  EXPECT_LT((second.translation - tracked.translation).norm(), 1e-12);
  EXPECT_LT((second.rotation - tracked.rotation).norm(), 1e-12);
  // Motion to eye image: the tracker's stamp to the frame written.
  ASSERT_TRUE(r.counters().stages().count("tracker_to_eye"));
  EXPECT_NEAR(r.counters().stages().at("tracker_to_eye").Percentile(50), 25.0, 1e-3);
}

// The latency budget's render stages (docs/latency.md): issue (its frameset's
// last sample taken to the pose written), tiles (pose to its last tile),
// transport_tile (the tile's DDS source timestamp to its take).
TEST_F(Render, TimesTheBudgetsStages) {
  RenderController r(Options(), clock_, assembler_, sink_);
  rig_.AddFrame(assembler_, 1, clock_.WallNs() - 40'000'000, false, /*arrival_ns=*/clock_.WallNs());
  clock_.Advance(0.004);
  r.Step();  // the pose goes out 4 ms after the frameset came in
  ASSERT_EQ(sink_.poses.size(), 1u);
  clock_.Advance(0.020);
  r.OnTile(WholeTile(sink_.poses[0], 2.0f, {10, 20, 30}), /*sent_ns=*/clock_.WallNs() - 3'000'000);
  r.Step();
  const auto& st = r.counters().stages();
  for (const char* s : {"issue", "tiles", "transport_tile", "composite", "write"}) ASSERT_TRUE(st.count(s)) << s;
  EXPECT_NEAR(st.at("issue").Percentile(50), 4.0, 1e-3);
  EXPECT_NEAR(st.at("tiles").Percentile(50), 20.0, 1e-3);
  EXPECT_NEAR(st.at("transport_tile").Percentile(50), 3.0, 1e-3);
}

// With a light (scenes with `light:`) the shadow map's hull part is made as
// the pose goes out (its own stage, light_hull), before any tile is in, not
// after the tiles; the frame is then lit. Without a light there is no such
// stage (the control).
TEST_F(Render, TheLightsHullDepthIsMadeWhileTheTilesAreSwept) {
  for (const bool lit : {true, false}) {
    SCOPED_TRACE(lit ? "light" : "no light");
    Recorder sink;
    RenderOptions o = Options();
    if (lit) {
      LightConfig light;
      light.position = hullpipe::test::kSphereCentre + Eigen::Vector3d(0.5, -0.5, -2.0);
      light.target = hullpipe::test::kSphereCentre;
      light.map_size = 64;
      o.light = light;
    }
    RenderController r(o, clock_, assembler_, sink);
    rig_.AddFrame(assembler_, lit ? 1 : 2, clock_.WallNs());  // one assembler: a frame each
    r.Step();
    ASSERT_EQ(sink.poses.size(), 1u);
    EXPECT_EQ(r.counters().stages().count("light_hull"), lit ? 1u : 0u);
    EXPECT_EQ(r.counters().stages().count("light"), 0u) << "nothing lit before the tiles";
    clock_.Advance(0.02);
    r.OnTile(WholeTile(sink.poses[0], 2.0f, {90, 90, 90}), clock_.WallNs());
    r.Step();
    ASSERT_EQ(sink.frames.size(), 1u);
    EXPECT_EQ(r.counters().stages().count("light"), lit ? 1u : 0u);
    if (lit) {
      EXPECT_EQ(r.counters().stages().at("light_hull").count(), 1u) << "made once, at the pose";
    }
  }
}

// floor: hull (docs/rigs.md): no floor is drawn until the first hull, then the
// plane up . x = that hull's lowest point along up (HullExtentAlong; not its
// box's corner); stats.json states it with the box, so a run shows whether the
// person stands on the floor.
TEST_F(Render, FloorUnderTheFirstHullIsStatedWithItsBox) {
  RenderOptions o = Options();
  o.floor = RigWorld::Floor::kUnderHull;
  RenderController r(o, clock_, assembler_, sink_);
  nlohmann::json w = r.StatsJson()["world"];
  EXPECT_TRUE(w["floor_height"].is_null()) << w.dump();  // no hull yet: no floor
  EXPECT_FALSE(w.contains("first_hull_box"));
  EXPECT_EQ(w["floor"], "hull");
  rig_.AddFrame(assembler_, 1, clock_.WallNs());
  r.Step();
  w = r.StatsJson()["world"];
  ASSERT_TRUE(w.contains("first_hull_box")) << w.dump();
  const Eigen::Vector3d up(w["up"][0], w["up"][1], w["up"][2]);
  EXPECT_NEAR((up - o.up.normalized()).norm(), 0, 1e-12);
  Aabb box;
  for (int k = 0; k < 3; ++k) box.min[k] = w["first_hull_box"]["min"][k], box.max[k] = w["first_hull_box"]["max"][k];
  double lowest = 1e300;
  for (const auto& c : box.Corners()) lowest = std::min(lowest, up.dot(c));
  ASSERT_FALSE(w["floor_height"].is_null());
  const double floor_h = w["floor_height"].get<double>();
  // The hull holds the sphere and its box holds the hull: the floor is
  // between the sphere's lowest point and the box's lowest corner, and not
  // far below the sphere (two cameras: a few centimetres).
  const double sphere_lowest = up.dot(hullpipe::test::kSphereCentre) - hullpipe::test::kSphereRadius;
  EXPECT_LE(floor_h, sphere_lowest + 1e-9);
  EXPECT_GE(floor_h, lowest - 1e-9);
  EXPECT_GT(floor_h, sphere_lowest - 0.3);
  // A stated floor plane is drawn from the start at its height.
  o.floor = RigWorld::Floor::kPlane;
  o.floor_height = 0.25;
  RenderController stated(o, clock_, assembler_, sink_);
  EXPECT_EQ(stated.StatsJson()["world"]["floor_height"], 0.25);
  o.floor = RigWorld::Floor::kNone;
  RenderController none(o, clock_, assembler_, sink_);
  EXPECT_TRUE(none.StatsJson()["world"]["floor_height"].is_null());
}

// CAD model parts: geometry once, each frameset a pose and a contact state.
// A part 2 m ahead is drawn in its base colour when clear, amber when near,
// red when colliding; depth-tested against the hull both ways; stats.json
// counts its frames in collision and its clearance.
TEST_F(Render, ModelPartsAreDrawnByContactStateAndCounted) {
  RenderOptions o = Options();
  o.max_in_flight = 1;
  RenderController r(o, clock_, assembler_, sink_);
  rig_.AddFrame(assembler_, 1, clock_.WallNs());
  r.Step();
  const NovelView view = sink_.poses[0].view;
  // A square 0.6 m across facing the eye, its body frame the eye's, 2 m ahead.
  ModelPartSample part;
  part.object_id = 1000;
  part.model_id = 1000;
  part.name = "oil filter";
  part.file = "engine.glb";
  part.vertices = {{-0.3f, -0.3f, 0}, {0.3f, -0.3f, 0}, {0.3f, 0.3f, 0}, {-0.3f, 0.3f, 0}};
  part.triangles = {{0, 1, 2}, {0, 2, 3}};
  part.colour = {200, 120, 40};
  r.OnModelPart(part);
  const Rigid3d body = view.world_from_eye * Rigid3d{Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, 2)};
  const Eigen::Quaterniond q(body.rotation);
  auto state = [&](uint64_t seq, uint8_t contact, double clearance) {
    ModelStateSample st;
    st.model_id = 1000;
    st.frame_seq = seq;
    st.triangles = 2;
    st.parts.push_back({body.translation, {q.w(), q.x(), q.y(), q.z()}, contact, clearance});
    return st;
  };
  std::vector<cv::Vec3b> seen;
  const std::vector<std::tuple<uint8_t, double, float>> steps = {
      {kPartClear, 0.09, kNoDepth}, {kPartNear, 0.03, kNoDepth}, {kPartColliding, 0.0, kNoDepth},
      {kPartColliding, 0.0, 1.0f}};  // last: a hull 1 m ahead hides the part
  for (size_t k = 0; k < steps.size(); ++k) {
    const uint64_t seq = k + 1;
    if (k > 0) {
      rig_.AddFrame(assembler_, seq, clock_.WallNs());
      r.Step();
    }
    r.OnModelState(state(seq, std::get<0>(steps[k]), std::get<1>(steps[k])));
    r.OnTile(WholeTile(sink_.poses.back(), std::get<2>(steps[k]), {0, 200, 0}));
    ASSERT_EQ(r.Step(), 1);
    seen.push_back(sink_.frames.back().second.at<cv::Vec3b>(24, 32));
  }
  // Clear: the base colour, shaded (blue dominates this BGR colour).
  EXPECT_GT(seen[0][0], seen[0][2]) << seen[0];
  // Near: amber (red and green over blue).
  EXPECT_GT(seen[1][2], 2 * seen[1][0]) << seen[1];
  EXPECT_GT(seen[1][1], 2 * seen[1][0]) << seen[1];
  EXPECT_TRUE(Red(seen[2])) << seen[2];
  EXPECT_EQ(seen[3], cv::Vec3b(0, 200, 0)) << "the hull in front hides the part";
  const nlohmann::json j = r.StatsJson();
  ASSERT_TRUE(j.contains("models"));
  const auto& m = j["models"][0];
  EXPECT_EQ(m["file"], "engine.glb");
  EXPECT_EQ(m["framesets"], 4);
  const auto& p = m["parts"][0];
  EXPECT_EQ(p["name"], "oil filter");
  EXPECT_EQ(p["frames_in_collision"], 2);
  EXPECT_EQ(p["frames_near"], 1);
  EXPECT_NEAR(p["clearance_mm_min"].get<double>(), 0.0, 1e-9);
  EXPECT_LE(p["clearance_mm_p50"].get<double>(), 30.0 + 1e-9);  // of 90, 30, 0, 0 mm
  EXPECT_NE(r.Table().find("model engine.glb: 2 triangles"), std::string::npos) << r.Table();
}

TEST_F(Render, StatsJsonSchema) {
  RenderController r(Options(), clock_, assembler_, sink_);
  rig_.AddFrame(assembler_, 1, clock_.WallNs() - 40'000'000);  // captured 40 ms ago
  r.Step();
  r.OnTile(WholeTile(sink_.poses[0], 2.0f, {10, 20, 30}));
  clock_.Advance(0.01);
  r.Step();
  NodeStatsSample recon;
  recon.name = "recon0";
  recon.fps = 30;
  recon.frames_out = 5;
  recon.stages["sweep"] = {12.5, 11.0, 20.0, 5};
  r.OnNodeStats(recon);
  VirtualMeshSample part;
  part.object_id = 301;
  part.frame_seq = 1;
  part.clearance = 0.05;
  r.OnMesh(part);
  const nlohmann::json j = r.StatsJson();
  for (const char* key : {"view", "frames_composited", "last_frame_seq", "collision_frames_drawn",
                          "collision_reports_with_points", "meshes_drawn", "lit_frames", "recon_outages",
                          "hull_pixel_fraction_mean", "world", "nodes"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["view"]["width"], 64);
  EXPECT_EQ(j["frames_composited"], 1);
  EXPECT_DOUBLE_EQ(j["hull_pixel_fraction_mean"].get<double>(), 1.0);
  EXPECT_EQ(j["nodes"]["recon0"]["fps"], 30.0);
  EXPECT_EQ(j["nodes"]["recon0"]["stages_ms"]["sweep"]["ms_p95"], 20.0);
  const auto& me = j["nodes"]["render"];
  for (const char* key : {"fps", "latency_ms_p50", "latency_ms_p95", "frames_in", "frames_out", "dropped",
                          "rejected", "stages_ms"})
    EXPECT_TRUE(me.contains(key)) << key;
  EXPECT_NEAR(me["latency_ms_p50"].get<double>(), 50.0, 1e-3);  // 40 ms before + 10 ms of fake time
  EXPECT_TRUE(me["stages_ms"].contains("composite"));
  EXPECT_TRUE(me["stages_ms"].contains("write"));
  EXPECT_EQ(j["nodes"]["recon0"]["stages_ms"]["sweep"]["ms_p50"], 11.0);
  // The latency budget: recon0's sweep and render's stages on the path.
  bool sweep_on_path = false, composite_on_path = false;
  for (const auto& row : j["latency_budget"]["rows"]) {
    if (row["node"] == "recon0" && row["stage"] == "sweep") sweep_on_path = row["on_path"];
    if (row["node"] == "render" && row["stage"] == "composite") composite_on_path = row["on_path"];
  }
  EXPECT_TRUE(sweep_on_path);
  EXPECT_TRUE(composite_on_path);
  EXPECT_NEAR(j["latency_budget"]["end_to_end_ms"]["p50"].get<double>(), 50.0, 1e-3);
  EXPECT_NE(r.Table().find("recon0"), std::string::npos);
  EXPECT_NE(r.Table().find("latency budget"), std::string::npos);
}

}  // namespace
}  // namespace hullpipe::nodes

namespace hullpipe::nodes {
namespace {

// render_node's world: the rig's, each flag given over it; the Utrecht rig's
// without a rig.
TEST(RenderOptions, TheWorldIsTheRigsWithTheFlagsOverIt) {
  RenderOptions none;
  none.ApplyWorld(nullptr, {});
  EXPECT_EQ(none.up, Eigen::Vector3d(0, 0, -1));
  EXPECT_EQ(none.floor, RigWorld::Floor::kPlane);
  EXPECT_EQ(none.floor_height, 0);

  RigWorld rig;
  rig.up = Eigen::Vector3d(0, 0, 1);
  rig.floor = RigWorld::Floor::kUnderHull;
  rig.orbit_radius = 5;
  rig.orbit_height = 1.5;
  RenderOptions o;
  o.ApplyWorld(&rig, {});
  EXPECT_EQ(o.up, rig.up);
  EXPECT_EQ(o.floor, RigWorld::Floor::kUnderHull);
  EXPECT_EQ(o.orbit_radius, 5);
  EXPECT_EQ(o.orbit_height, 1.5);

  WorldFlags f;
  f.up = Eigen::Vector3d(0, 1, 0);
  f.orbit_radius = 2;
  f.floor = "-0.25";
  o.ApplyWorld(&rig, f);
  EXPECT_EQ(o.up, Eigen::Vector3d(0, 1, 0));
  EXPECT_EQ(o.orbit_radius, 2);
  EXPECT_EQ(o.orbit_height, 1.5);  // not given: the rig's
  EXPECT_EQ(o.floor, RigWorld::Floor::kPlane);
  EXPECT_EQ(o.floor_height, -0.25);
  f.floor = "none";
  o.ApplyWorld(&rig, f);
  EXPECT_EQ(o.floor, RigWorld::Floor::kNone);
  for (const char* bad : {"low", "1m", "nan", ""}) {
    f.floor = bad;
    if (f.floor.empty()) continue;  // (empty: the rig's)
    try {
      o.ApplyWorld(&rig, f);
      ADD_FAILURE() << bad << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("--floor"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace hullpipe::nodes

namespace hullpipe::nodes {
namespace {

// Parses render_node's flags as its main does (CLI11), then resolves them.
RenderFlags Parse(std::vector<std::string> args, bool have_display = false) {
  CLI::App app;
  RenderFlags flags;
  flags.Register(app);
  std::reverse(args.begin(), args.end());  // CLI11 takes them in reverse
  app.parse(args);
  flags.Resolve(have_display);
  return flags;
}

TEST(RenderFlags, ParsedAndResolvedOnce) {
  const RenderFlags d = Parse({});
  EXPECT_EQ(d.options.up, Eigen::Vector3d(0, 0, -1));  // the Utrecht rig's world
  EXPECT_EQ(d.options.orbit_radius, 3.0);
  EXPECT_FALSE(d.outputs.show);
  EXPECT_TRUE(Parse({}, /*have_display=*/true).outputs.show);
  EXPECT_FALSE(Parse({"--window", "off"}, true).outputs.show);

  const RenderFlags f = Parse({"--up", "0,1,0", "--floor", "none", "--orbit-radius", "4.5", "--out", "/tmp/x",
                               "--png-every", "10", "--width", "64", "--orbit-centre", "1,2,3"});
  EXPECT_EQ(f.options.up, Eigen::Vector3d(0, 1, 0));
  EXPECT_EQ(f.options.floor, RigWorld::Floor::kNone);
  EXPECT_EQ(f.options.orbit_radius, 4.5);
  EXPECT_EQ(f.options.orbit_height, 0.7);
  EXPECT_EQ(f.outputs.out_dir, "/tmp/x");
  EXPECT_EQ(f.outputs.png_every, 10);
  EXPECT_EQ(f.options.width, 64);
  ASSERT_TRUE(f.options.orbit_centre.has_value());
  EXPECT_EQ(*f.options.orbit_centre, Eigen::Vector3d(1, 2, 3));

  // Refusals name the flag: at the parse, or when resolving.
  EXPECT_THROW(Parse({"--video-fps", "nan"}), CLI::ValidationError);
  EXPECT_THROW(Parse({"--view", "sky"}), CLI::ValidationError);
  for (const auto& [args, flag] : std::vector<std::pair<std::vector<std::string>, std::string>>{
           {{"--view", "file"}, "--head-poses"},
           {{"--view", "eyes"}, "--eye-views"},
           {{"--view", "eyes-topic", "--eye-views", HULLPIPE_SOURCE_DIR "/scenes/eye_views_example.csv"},
            "--eye-views"},
           {{"--ipd", "0.07"}, "--stereo"},
           {{"--view", "eyes-topic", "--fov-left", "-0.8,0.7,0.8,-0.8"}, "--fov-left"},
           {{"--stereo", "--ipd", "0.2"}, "--ipd"},
           {{"--stereo", "--fov-left", "0.5,0.2,0.8,-0.8"}, "--fov-left"},
           {{"--floor", "low"}, "--floor"},
           {{"--width", "0"}, "--width"}}) {
    try {
      Parse(args);
      ADD_FAILURE() << flag << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(flag), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace hullpipe::nodes
