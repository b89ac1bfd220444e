#include "hullpipe/nodes/recon_controller.h"

#include <gtest/gtest.h>

#include "hullpipe/nodes/test_rig.h"
#include "hullpipe/reconstruction/stereo_views.h"

namespace hullpipe::nodes {
namespace {

struct TileRecorder final : ReconSink {
  std::vector<HullTile> tiles;
  void PublishTile(const HullTile& t, uint32_t) override { tiles.push_back(t); }
};

class Recon : public ::testing::Test {
 protected:
  Recon() { rig_.Calibrate(assembler_); }
  ReconOptions Options(const std::string& tile) const {
    ReconOptions o;
    o.ParseTile(tile);
    o.sweep.num_planes = 24;
    o.refine = 0;
    o.visibility_width = 0;
    return o;
  }
  NovelView View() const { return hullpipe::test::SphereSideView(48, 36); }
  FakeClock clock_;
  FramesetAssembler assembler_{8, true};
  test::TinyRig rig_;
  std::unique_ptr<SweepBackend> cpu_ = MakeCpuSweepBackend(1, 0);
  TileRecorder sink_;
};

TEST_F(Recon, TileSpecAndOptionsAreChecked) {
  ReconOptions o;
  EXPECT_THROW(o.ParseTile("2/2"), std::invalid_argument);
  EXPECT_THROW(o.ParseTile("1/0"), std::invalid_argument);
  EXPECT_THROW(o.ParseTile("x"), std::invalid_argument);
  EXPECT_THROW(o.ParseTile("0/2junk"), std::invalid_argument);
  EXPECT_NO_THROW(o.ParseTile("1/2"));
  EXPECT_EQ(o.NodeName(), "recon1");
  o.failover = 0;
  EXPECT_THROW(o.Check(), std::invalid_argument);
}

// --threads 0 (the default): the host's cores shared among the recon nodes
// reporting its host name; a peer on another host, or one that stopped, shares
// nothing; a thread count given is kept (the control).
TEST_F(Recon, ThreadsDefaultToTheHostsCoresSharedAmongItsReconNodes) {
  ReconOptions o = Options("0/3");
  o.host_cores = 16;
  ReconController r(o, clock_, assembler_, *cpu_, sink_);
  const std::string here = r.counters().host();
  ASSERT_FALSE(here.empty());
  EXPECT_EQ(r.ThreadsNow(), 16) << "alone";
  r.OnNodeStats("recon1", false, 0, here);
  EXPECT_EQ(r.ThreadsNow(), 8);
  r.OnNodeStats("recon2", false, 0, here + "-other");
  EXPECT_EQ(r.ThreadsNow(), 8) << "a peer on another host takes none of these cores";
  r.OnNodeStats("recon2", false, 0, here);
  EXPECT_EQ(r.ThreadsNow(), 5);
  r.OnNodeStats("recon1", /*final_report=*/true, 0, here);
  EXPECT_EQ(r.ThreadsNow(), 8) << "a stopped peer shares nothing";
  o.host_cores = 1;
  ReconController small(o, clock_, assembler_, *cpu_, sink_);
  small.OnNodeStats("recon1", false, 0, here);
  EXPECT_EQ(small.ThreadsNow(), 1) << "never below one";
  o.threads = 3;
  ReconController fixed(o, clock_, assembler_, *cpu_, sink_);
  fixed.OnNodeStats("recon1", false, 0, here);
  EXPECT_EQ(fixed.ThreadsNow(), 3);
  // The frameset is swept with them.
  rig_.AddFrame(assembler_, 1, clock_.WallNs(), true);
  fixed.OnPose(View(), 1, 1);
  EXPECT_EQ(fixed.Step(), 1);
  EXPECT_EQ(cpu_->threads(), 3);
  o.threads = -1;
  EXPECT_THROW(o.Check(), std::invalid_argument);
}

// The latency budget's recon stages (docs/latency.md): "wait" runs from the
// frameset's last sample taken to the node starting on it, on the node's clock.
TEST_F(Recon, TimesEachBudgetStageFromTheFramesetsLastArrival) {
  ReconController r(Options("0/1"), clock_, assembler_, *cpu_, sink_);
  rig_.AddFrame(assembler_, 5, clock_.WallNs(), /*images=*/true, /*arrival_ns=*/clock_.WallNs());
  clock_.Advance(0.030);  // the pose naming it comes 30 ms later
  r.OnPose(View(), 1, 5);
  ASSERT_EQ(r.Step(), 1);
  const auto& stages = r.counters().stages();
  ASSERT_TRUE(stages.count("wait"));
  EXPECT_NEAR(stages.at("wait").Percentile(50), 30.0, 1e-3);
  for (const char* s : {"hull_box", "upload", "sweep", "refine", "texture", "publish"}) {
    ASSERT_TRUE(stages.count(s)) << s;
    EXPECT_EQ(stages.at(s).count(), 1u) << s;
  }
  // A frameset whose arrival is unknown (a test assembler, a replay) gives no wait sample.
  rig_.AddFrame(assembler_, 6, clock_.WallNs(), /*images=*/true);
  r.OnPose(View(), 2, 6);
  ASSERT_EQ(r.Step(), 1);
  EXPECT_EQ(stages.at("wait").count(), 1u);
  EXPECT_EQ(stages.at("sweep").count(), 2u);
}

TEST_F(Recon, ServesAPoseWhenItsFramesetIsCompleteWithTheCpuSweepsDepth) {
  ReconController r(Options("0/1"), clock_, assembler_, *cpu_, sink_);
  r.OnPose(View(), 1, 5);
  EXPECT_EQ(r.Step(), 0);  // frameset 5 not here yet: the pose waits
  rig_.AddFrame(assembler_, 5, clock_.WallNs(), /*images=*/true);
  ASSERT_EQ(r.Step(), 1);
  const HullTile& t = sink_.tiles[0];
  EXPECT_EQ(t.pose_seq, 1u);
  EXPECT_EQ(t.frame_seq, 5u);
  EXPECT_EQ(t.rect, cv::Rect(0, 0, 48, 36));
  // The same sweep run directly gives the same depths, pixel for pixel.
  const VolumeQuery q(rig_.views, hullpipe::test::BigBox());
  PlaneSweepOptions so;
  so.num_planes = 24;
  const cv::Mat ref = PlaneSweepCpu(q, View(), SweepPlaneDepths(q, View(), so), t.rect);
  EXPECT_EQ(cv::norm(t.depth, ref, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::countNonZero(ref < 1e6), 0) << "the sphere is in view";
}

TEST_F(Recon, ANewerReadyPoseSupersedesAndAMissingFramesetTimesOut) {
  ReconController r(Options("0/1"), clock_, assembler_, *cpu_, sink_);
  rig_.AddFrame(assembler_, 1, clock_.WallNs(), true);
  rig_.AddFrame(assembler_, 2, clock_.WallNs(), true);
  r.OnPose(View(), 1, 1);
  r.OnPose(View(), 2, 2);
  EXPECT_EQ(r.Step(), 1);
  ASSERT_EQ(sink_.tiles.size(), 1u);
  EXPECT_EQ(sink_.tiles[0].frame_seq, 2u);
  EXPECT_EQ(r.poses_dropped(), 1u);
  r.OnPose(View(), 3, 9);  // never arrives
  r.Step();
  clock_.Advance(1.1);
  EXPECT_EQ(r.Step(), 0);
  EXPECT_EQ(r.poses_dropped(), 2u);
  // A pose for a frameset already gone is dropped at once.
  r.OnPose(View(), 4, 1);
  r.Step();
  EXPECT_EQ(r.poses_dropped(), 3u);
}

// A head-mounted display's two eyes (render_node --stereo): two poses naming one
// frameset, whether they arrive together or the second after the first was
// served. Each is served with its own view's sweep, equal to a direct sweep
// from that eye, and the frameset's query, upload and visibility maps are made
// once for both. Control: a pose naming a newer ready frameset still
// supersedes the older frameset's poses.
TEST_F(Recon, TwoEyesOfOneFramesetAreBothServedFromOneQuery) {
  ReconOptions o = Options("0/1");
  o.visibility_width = 24;
  ReconController r(o, clock_, assembler_, *cpu_, sink_);
  const StereoOptions so = [] {
    StereoOptions s;
    s.width = 48, s.height = 36;
    return s;
  }();
  const StereoViews eyes = MakeStereoViews(View().world_from_eye, so);
  const auto& stages = r.counters().stages();
  auto direct = [&](const NovelView& v, const cv::Rect& rect) {
    const VolumeQuery q(rig_.views, hullpipe::test::BigBox());
    PlaneSweepOptions ps;
    ps.num_planes = 24;
    return PlaneSweepCpu(q, v, SweepPlaneDepths(q, v, ps), rect);
  };
  rig_.AddFrame(assembler_, 1, clock_.WallNs(), true);
  r.OnPose(eyes.eye[0], 1, 1);
  r.OnPose(eyes.eye[1], 2, 1);
  ASSERT_EQ(r.Step(), 2) << "both eyes, queued together";
  ASSERT_EQ(sink_.tiles.size(), 2u);
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(sink_.tiles[size_t(k)].pose_seq, uint64_t(k + 1));
    EXPECT_EQ(sink_.tiles[size_t(k)].frame_seq, 1u);
    EXPECT_EQ(cv::norm(sink_.tiles[size_t(k)].depth, direct(eyes.eye[size_t(k)], sink_.tiles[size_t(k)].rect),
                       cv::NORM_INF),
              0.0)
        << "eye " << k;
  }
  EXPECT_GT(cv::norm(sink_.tiles[0].depth != sink_.tiles[1].depth, cv::NORM_L1), 0.0) << "the eyes differ";
  for (const char* st : {"hull_box", "upload", "visibility", "wait"})
    EXPECT_LE(stages.count(st) ? stages.at(st).count() : 0u, 1u) << st << ": once for the frameset";
  EXPECT_EQ(stages.at("hull_box").count(), 1u);
  EXPECT_EQ(stages.at("sweep").count(), 2u);
  EXPECT_EQ(r.poses_dropped(), 0u);
  // The right eye's pose after the left was served: from the same query.
  rig_.AddFrame(assembler_, 2, clock_.WallNs(), true);
  r.OnPose(eyes.eye[0], 3, 2);
  ASSERT_EQ(r.Step(), 1);
  r.OnPose(eyes.eye[1], 4, 2);
  ASSERT_EQ(r.Step(), 1) << "the frameset was taken, but is kept for its other eye";
  EXPECT_EQ(sink_.tiles.back().pose_seq, 4u);
  EXPECT_EQ(cv::norm(sink_.tiles.back().depth, direct(eyes.eye[1], sink_.tiles.back().rect), cv::NORM_INF), 0.0);
  EXPECT_EQ(stages.at("hull_box").count(), 2u);
  EXPECT_EQ(stages.at("sweep").count(), 4u);
  // Control: frameset 3's eyes queued behind frameset 4's, both ready: 3's are
  // superseded, 4's both served.
  rig_.AddFrame(assembler_, 3, clock_.WallNs(), true);
  rig_.AddFrame(assembler_, 4, clock_.WallNs(), true);
  for (uint64_t k = 0; k < 4; ++k) r.OnPose(eyes.eye[k % 2], 5 + k, 3 + k / 2);
  ASSERT_EQ(r.Step(), 2);
  EXPECT_EQ(r.poses_dropped(), 2u);
  EXPECT_EQ(sink_.tiles[sink_.tiles.size() - 2].pose_seq, 7u);
  EXPECT_EQ(sink_.tiles.back().pose_seq, 8u);
  EXPECT_EQ(sink_.tiles.back().frame_seq, 4u);
}

TEST_F(Recon, TheLowestLiveNodeAdoptsASilentPeersTileUntilItIsHeardAgain) {
  ReconController r0(Options("0/2"), clock_, assembler_, *cpu_, sink_);
  TileRecorder sink1;
  ReconController r1(Options("1/2"), clock_, assembler_, *cpu_, sink1);
  EXPECT_EQ(r0.MyTiles(), std::vector<int>({0}));
  clock_.Advance(1.0);
  EXPECT_EQ(r0.MyTiles(), std::vector<int>({0})) << "peers count as heard at the start";
  clock_.Advance(0.3);  // recon1 silent 1.3 s > failover 1.2 s
  EXPECT_EQ(r0.MyTiles(), std::vector<int>({0, 1}));
  // recon1's view: recon0 is also silent (never heard), so recon1 is the lowest live and adopts tile 0.
  EXPECT_EQ(r1.MyTiles(), std::vector<int>({1, 0}));
  r1.OnNodeStats("recon0", false);
  EXPECT_EQ(r1.MyTiles(), std::vector<int>({1})) << "recon0 is alive and lower: it adopts, not recon1";
  r0.OnNodeStats("recon1", false);
  EXPECT_EQ(r0.MyTiles(), std::vector<int>({0}));
  r0.OnNodeStats("recon1", /*final_report=*/true);  // stopping: adopted at once
  EXPECT_EQ(r0.MyTiles(), std::vector<int>({0, 1}));
  // With the adopted tile, one frameset gives both tiles.
  rig_.AddFrame(assembler_, 1, clock_.WallNs(), true);
  r0.OnPose(View(), 1, 1);
  EXPECT_EQ(r0.Step(), 2);
  EXPECT_EQ(sink_.tiles[0].tile_index, 0u);
  EXPECT_EQ(sink_.tiles[1].tile_index, 1u);
  EXPECT_EQ(sink_.tiles[0].rect.height + sink_.tiles[1].rect.height, 36);
  // Names that are not recon peers are ignored.
  r0.OnNodeStats("render", false);
  r0.OnNodeStats("recon7", false);
  r0.OnNodeStats("recon1x", false);
  r0.OnNodeStats("recon01", false);  // another spelling of 1: not recon1's name
  r0.OnNodeStats("recon+1", false);
  EXPECT_EQ(r0.MyTiles(), std::vector<int>({0, 1}));
}

// Replaying a whole recording into a live run put the recorded run's poses on
// the wire beside render's: recon served both. A pose of another run is ignored
// and counted; this run's pose is served (the control) and its tile carries the
// run id back; a peer's report from another run does not keep it alive.
TEST_F(Recon, PosesAndPeerReportsOfAnotherRunAreIgnored) {
  ReconOptions o = Options("0/2");
  o.run_id = 0xa;
  ReconController r(o, clock_, assembler_, *cpu_, sink_);
  rig_.AddFrame(assembler_, 1, clock_.WallNs(), true);
  r.OnPose(View(), 1, 1, /*run_id=*/0xb);
  r.OnPose(View(), 2, 1, /*run_id=*/0);  // a pose without a run id is not this run's either
  EXPECT_EQ(r.Step(), 0);
  EXPECT_EQ(r.runs().ignored().at("ViewPose"), 2u);
  r.OnPose(View(), 3, 1, 0xa);
  ASSERT_EQ(r.Step(), 1);
  EXPECT_EQ(sink_.tiles[0].pose_seq, 3u);
  EXPECT_EQ(sink_.tiles[0].run_id, 0xau);
  // recon1 of another run keeps reporting; this run's recon1 is silent: adopted.
  clock_.Advance(0.6);
  r.OnNodeStats("recon1", false, 0xb);
  clock_.Advance(0.7);
  r.OnNodeStats("recon1", false, 0xb);
  EXPECT_EQ(r.MyTiles(), std::vector<int>({0, 1}));
  EXPECT_EQ(r.runs().ignored().at("NodeStats"), 2u);
  r.OnNodeStats("recon1", false, 0xa);  // control: this run's report is taken
  EXPECT_EQ(r.MyTiles(), std::vector<int>({0}));
  r.OnNodeStats("recon1", false, 0);  // a node started without --run-id: taken
  EXPECT_EQ(r.runs().ignored().at("NodeStats"), 2u);
  // Without a run id of its own, recon serves any run's pose.
  TileRecorder any;
  ReconController free_run(Options("0/1"), clock_, assembler_, *cpu_, any);
  rig_.AddFrame(assembler_, 2, clock_.WallNs(), true);
  free_run.OnPose(View(), 9, 2, 0xb);
  EXPECT_EQ(free_run.Step(), 1);
  EXPECT_EQ(any.tiles.at(0).run_id, 0xbu);
}

}  // namespace
}  // namespace hullpipe::nodes
