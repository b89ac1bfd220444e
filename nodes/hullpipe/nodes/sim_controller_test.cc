#include "hullpipe/nodes/sim_controller.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include "hullpipe/collision/hull_surface.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/nodes/test_rig.h"
#include "hullpipe/scenes/ball.h"
#include "hullpipe/scenes/scene_config.h"

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

// A model of 300 small parts, every one inside the hull at once: 300 part
// collisions start in one frameset. Each used to be one log line (a 200,000-part
// model wrote 19 MB of log in one frame); now at most the burst of lines is
// logged one by one and one line says how many more there were, once the rate
// allows, and the counts hold every event. The control: a model of 3 parts logs
// each of its events.
TEST(Sim, PartCollisionEventsAreLoggedAtABoundedRateWithCounts) {
  for (const int n_parts : {3, 300}) {
    const auto dir = hullpipe::test::TempDir("sim_part_events");
    {
      std::ofstream o(dir / "parts.obj");
      for (int k = 0; k < n_parts; ++k)
        hullpipe::test::WriteObjCube(
            o, "p" + std::to_string(k),
            hullpipe::test::kSphereCentre + Eigen::Vector3d(0.002 * (k % 10), 0.002 * (k / 10 % 10), 0.002 * (k / 100)),
            0.001, 8 * k);
    }
    std::ofstream(dir / "scene.yaml")
        << "balls: []\nmodels:\n  - {file: parts.obj, units: m, up: -z, anchor: origin}\n";
    const SceneConfig scene = LoadSceneConfig((dir / "scene.yaml").string());
    FakeClock clock;
    FramesetAssembler assembler(6, false);
    test::TinyRig rig;
    rig.Calibrate(assembler);
    SimRecorder sink;
    auto lines = std::make_shared<std::ostringstream>();
    auto previous = spdlog::default_logger();
    spdlog::set_default_logger(
        std::make_shared<spdlog::logger>("sim", std::make_shared<spdlog::sinks::ostream_sink_mt>(*lines)));
    SimController sim(scene, clock, assembler, sink);
    rig.AddFrame(assembler, 1, clock.WallNs());
    EXPECT_EQ(sim.Step(), 1);
    rig.AddFrame(assembler, 26, clock.WallNs());  // one second of source time later: the rate allows a line
    EXPECT_EQ(sim.Step(), 1);
    spdlog::set_default_logger(previous);
    const std::string log = lines->str();
    size_t one_by_one = 0;
    for (size_t at = log.find("starts collision"); at != std::string::npos; at = log.find("starts collision", at + 1))
      ++one_by_one;
    EXPECT_EQ(sim.part_events(), uint64_t(n_parts)) << log;  // every part starts, none ends
    if (n_parts == 3) {
      EXPECT_EQ(one_by_one, 3u) << log;
      EXPECT_EQ(sim.part_events_unlogged(), 0u);
      EXPECT_EQ(log.find("not logged one by one"), std::string::npos) << log;
    } else {
      EXPECT_EQ(one_by_one, size_t(SimController::kPartEventBurst)) << log;
      EXPECT_EQ(sim.part_events_unlogged(), uint64_t(n_parts - SimController::kPartEventBurst));
      EXPECT_NE(log.find("280 more part collision start(s)/end(s) not logged one by one"), std::string::npos) << log;
    }
  }
}

TEST(Sim, StepsByTheFramesSourceTimeAndPublishesEachBody) {
  FakeClock clock;
  FramesetAssembler assembler(6, false);
  test::TinyRig rig;
  rig.Calibrate(assembler);
  const SceneConfig scene = DefaultScene();  // one ball
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
  EXPECT_EQ(sink.states[0].object_id, uint32_t(scene.Find<BallsConfig>()->balls[0].id));
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
    SimController sim(DefaultScene(), clock, assembler, sink);
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
  // A peer flooding bad commands: every one counted, their lines a burst and
  // then one a second (RejectLog), on the node's clock.
  for (int i = 0; i < 5000; ++i) {
    sim.RejectCommand(uint64_t(100 + i), "unknown command 9");
    clock.Advance(1e-3);
  }
  EXPECT_EQ(sim.commands_rejected(), 5003u);
  EXPECT_LE(sim.reject_log().lines(), RejectLog::kBurst + 2 + 5 + 1);  // the first 3, then ~5 s
  EXPECT_GE(sim.reject_log().lines(), RejectLog::kBurst + 4);
}

// The previous frameset's hull is kept and timed by the frames' capture times:
// a sphere moving at 1 m/s towards a ball at rest throws it, and the ball's
// report says how fast the hull's surface moved; with `hull_velocity: {enabled:
// false}` the ball is only pushed out (the paper's response) and the reports say
// none was estimated.
TEST(Sim, AMovingHullThrowsTheBallItStrikesUnlessTurnedOff) {
  const Eigen::Vector3d c0 = hullpipe::test::kSphereCentre, d(1, 0, 0);
  const double speed = 1.0, fps = 25;
  const auto cams = RingCameras(4, 3.0, 1.6, c0, 320, 240, 0.9);
  auto scene_at = [&](int k) { return SyntheticScene{{Shape::Sphere(c0 + speed * (k / fps) * d, 0.1)}}; };
  std::vector<CameraMap> first;
  for (const auto& c : cams) first.push_back({c, RenderExactMap(c, scene_at(0))});
  const auto front = FirstHullPointAlong(VolumeQuery(first, hullpipe::test::BigBox()), c0 + d, -d, 1.0);
  ASSERT_TRUE(front);
  for (const bool enabled : {true, false}) {
    FakeClock clock;
    FramesetAssembler assembler(6, false);
    for (const auto& c : cams) assembler.SetCamera(c);
    assembler.SetWorkspace(hullpipe::test::BigBox());
    SceneConfig scene;
    scene.has_floor = false;
    scene.gravity.setZero();
    scene.hull_velocity.enabled = enabled;
    BallConfig ball;
    ball.radius = 0.05;
    ball.start = ball.target = *front + (0.05 + 0.6 * speed / fps) * d;
    ball.rethrow_period = 0;
    ball.restitution = 0.5;
    scene.Set(BallsConfig({ball}));
    SimRecorder sink;
    SimController sim(scene, clock, assembler, sink);
    // The same run with the hull box searched on 4 threads: the same steps,
    // bit for bit (the box is the same with any number of threads).
    FakeClock clock4;
    FramesetAssembler assembler4(6, false);
    for (const auto& c : cams) assembler4.SetCamera(c);
    assembler4.SetWorkspace(hullpipe::test::BigBox());
    SimRecorder sink4;
    SimController sim4(scene, clock4, assembler4, sink4);
    sim4.set_query_threads(4);
    for (int k = 0; k <= 3; ++k) {
      for (const auto& c : cams) {
        MapSample m{.camera_id = c.id, .seq = uint64_t(k + 1),
                    .capture_time_ns = 1'000'000'000 + int64_t(k) * 40'000'000, .camera_count = 4,
                    .map = RenderExactMap(c, scene_at(k)), .source_time_s = k / fps};
        assembler4.AddMap(m);
        assembler.AddMap(std::move(m));
      }
      ASSERT_EQ(sim.Step(), 1);
      ASSERT_EQ(sim4.Step(), 1);
    }
    ASSERT_EQ(sink4.states.size(), sink.states.size());
    for (size_t i = 0; i < sink.states.size(); ++i) {
      EXPECT_EQ(sink4.states[i].position, sink.states[i].position) << i;
      EXPECT_EQ(sink4.states[i].velocity, sink.states[i].velocity) << i;
    }
    const CollisionReportSample* hit = nullptr;
    for (const auto& r : sink.reports)
      if (r.has_response && !hit) hit = &r;
    ASSERT_NE(hit, nullptr) << "the sphere reached the ball";
    const double after = sink.states.back().velocity.dot(d);
    if (enabled) {
      EXPECT_EQ(hit->hull_velocity_status, uint8_t(HullVelocityStatus::kMeasured));
      EXPECT_NEAR(hit->hull_velocity_interval, 0.04, 1e-9);
      // 320x240 cameras 3 m away: 1.42 px of quantization is about 1.4 cm,
      // over 40 ms 0.35 m/s.
      EXPECT_NEAR(hit->hull_normal_speed, speed * d.dot(hit->n_hull), 0.35 + 0.05);
      EXPECT_GT(after, 1.0) << "thrown";
      EXPECT_GE(sim.hull_velocity_counts()[size_t(HullVelocityStatus::kMeasured)], 1u);
    } else {
      EXPECT_EQ(hit->hull_velocity_status, uint8_t(HullVelocityStatus::kNone));
      EXPECT_EQ(after, 0.0) << "pushed out, not thrown";
      EXPECT_GE(sim.hull_velocity_counts()[size_t(HullVelocityStatus::kNone)], 1u);
    }
  }
}

}  // namespace
}  // namespace hullpipe::nodes
