#include "hullpipe/nodes/sim_controller.h"

#include <gtest/gtest.h>

#include "hullpipe/nodes/test_rig.h"

namespace hullpipe::nodes {
namespace {

struct SimRecorder final : SimSink {
  std::vector<VirtualObjectSample> states;
  std::vector<CollisionReportSample> reports;
  std::vector<VirtualMeshSample> meshes;
  void PublishState(const VirtualObjectSample& s) override { states.push_back(s); }
  void PublishReport(const CollisionReportSample& r) override { reports.push_back(r); }
  void PublishMesh(const VirtualMeshSample& m) override { meshes.push_back(m); }
  void PublishModelPart(const ModelPartSample& p) override { model_parts.push_back(p); }
  void PublishModelState(const ModelStateSample& s) override { model_states.push_back(s); }
  std::vector<ModelPartSample> model_parts;
  std::vector<ModelStateSample> model_states;
};

TEST(Sim, StepsByTheFramesSourceTimeAndPublishesEachBody) {
  FakeClock clock;
  FramesetAssembler assembler(6, false);
  test::TinyRig rig;
  rig.Calibrate(assembler);
  SceneConfig scene;  // one ball
  SimRecorder sink;
  SimController sim(scene, clock, assembler, sink);
  EXPECT_EQ(sim.Step(), 0);
  rig.AddFrame(assembler, 1, clock.WallNs());  // source time 1/25 s
  EXPECT_EQ(sim.Step(), 1);
  clock.Advance(5.0);  // the wall clock does not drive the simulation
  rig.AddFrame(assembler, 3, clock.WallNs());  // source time 3/25 s
  EXPECT_EQ(sim.Step(), 1);
  ASSERT_EQ(sink.states.size(), 2u);
  ASSERT_EQ(sink.reports.size(), 2u);
  EXPECT_EQ(sink.states[1].frame_seq, 3u);
  EXPECT_NEAR(sink.states[1].sim_time - sink.states[0].sim_time, 2.0 / 25.0, 1e-12);
  EXPECT_EQ(sink.states[0].object_id, uint32_t(scene.balls[0].id));
  EXPECT_TRUE(sink.meshes.empty()) << "no cloth, particles or payload in the default scene";
  EXPECT_EQ(sim.counters().frames_out(), 2u);
}

// Three complete framesets waiting: the default steps the newest only (live use:
// never fall behind); --every-frameset steps all three, oldest first (replays).
TEST(Sim, EveryFramesetStepsEachCompleteFramesetInOrder) {
  for (const bool every : {false, true}) {
    FakeClock clock;
    FramesetAssembler assembler(6, false);
    test::TinyRig rig;
    rig.Calibrate(assembler);
    SimRecorder sink;
    SimController sim(SceneConfig{}, clock, assembler, sink);
    sim.set_every_frameset(every);
    for (uint64_t seq = 1; seq <= 3; ++seq) rig.AddFrame(assembler, seq, clock.WallNs());
    EXPECT_EQ(sim.Step(), every ? 3 : 1);
    ASSERT_EQ(sink.states.size(), every ? 3u : 1u);
    EXPECT_EQ(sink.states.front().frame_seq, every ? 1u : 3u);
    EXPECT_EQ(sink.states.back().frame_seq, 3u);
  }
}

TEST(Sim, SpacingCommandsAreValidatedAndCounted) {
  FakeClock clock;
  FramesetAssembler assembler(6, false);
  SimRecorder sink;
  SimController plain(SceneConfig{}, clock, assembler, sink);
  EXPECT_FALSE(plain.SetSpacing(0.14, 1)) << "no payload task in this scene";
  EXPECT_EQ(plain.commands_rejected(), 1u);

  SceneConfig with_payload;
  with_payload.Set(PayloadConfig{});
  SimController sim(with_payload, clock, assembler, sink);
  EXPECT_FALSE(sim.SetSpacing(std::nan(""), 2));
  EXPECT_FALSE(sim.SetSpacing(-1.0, 3));
  EXPECT_TRUE(sim.SetSpacing(0.2, 4));
  EXPECT_DOUBLE_EQ(sim.scene().payload()->spacing, 0.2);
  sim.RejectCommand(5, "unknown command 9");
  EXPECT_EQ(sim.commands_rejected(), 3u);
  sim.Step();
  EXPECT_EQ(sim.counters().rejected(), 3u);
}

}  // namespace
}  // namespace hullpipe::nodes
