// sim_node: the virtual scene (paper §4–§5). Parses flags and connects DDS to a
// SimController (nodes/sim_controller.h), which steps the scene against each new
// frameset's visual hull and publishes states, collision reports and meshes.
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/geometry/calibration.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/frameset_input.h"
#include "hullpipe/util/parallel.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/gl/backend.h"
#include "hullpipe/nodes/sim_controller.h"
#include "hullpipe/scenes/model_scene.h"
#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/util/logging.h"

using namespace hullpipe;
using namespace hullpipe::dds;

namespace {

class SimWriters final : public nodes::SimSink {
 public:
  explicit SimWriters(const Participant& p) : states_(p), reports_(p), meshes_(p), parts_(p), models_(p) {}
  void PublishState(const VirtualObjectSample& s) override { states_.Write(VirtualObjectToMsg(s)); }
  void PublishReport(const CollisionReportSample& r) override { reports_.Write(MakeCollisionReportMessage(r).msg); }
  void PublishMesh(const VirtualMeshSample& m) override { meshes_.Write(MakeVirtualMeshMessage(m).msg); }
  void PublishModelPart(const ModelPartSample& p) override { parts_.Write(MakeModelPartMessage(p).msg); }
  void PublishModelState(const ModelStateSample& s) override { models_.Write(MakeModelStateMessage(s).msg); }

 private:
  Writer<hullpipe_msg_VirtualObjectState> states_;
  Writer<hullpipe_msg_CollisionReport> reports_;
  Writer<hullpipe_msg_VirtualMesh> meshes_;
  Writer<hullpipe_msg_ModelPart> parts_;
  Writer<hullpipe_msg_ModelState> models_;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hullpipe sim_node: virtual scene colliding with the visual hull"};
  CommonOptions common;
  OpenCommandLine(argc, argv, "sim", app, common, /*with_run_id=*/true);
  std::string scene_path;
  app.add_option("--scene", scene_path, "Scene file (YAML); default: one ball");
  std::string rig_path;
  app.add_option("--rig", rig_path,
                 "Rig directory or YAML rig file whose world (up, floor) and workspace place a `frame: stage` scene "
                 "(default: the Utrecht rig's world: up -z, floor z = 0, the stage's origin at the world's)");
  FramesetOptions frameset_options;
  AddFramesetOptions(app, frameset_options);
  int model_threads = 1;
  app.add_option("--model-threads", model_threads,
                 "Threads for the CAD models' triangle query and clearances (0: every core; default 1, as the other "
                 "nodes share this machine's cores)")
      ->check(CLI::Range(0, 256))
      ->capture_default_str();
  int threads = 0;
  app.add_option("--threads", threads,
                 "Threads of each frameset's hull box search, its six faces at once (0: this host's cores, at most "
                 "6); the box is the same with any number")
      ->check(CLI::Range(0, 256))
      ->capture_default_str();
  std::string backend_name = "auto";
  app.add_option("--backend", backend_name,
                 "Triangle query of the CAD models: cpu|gl|auto (auto: GL on a hardware GPU, the CPU on a software "
                 "renderer or without one)")
      ->check(CLI::IsMember({"cpu", "gl", "auto"}))
      ->capture_default_str();
  int gl_device = -1;
  app.add_option("--gl-device", gl_device, "EGL device index for --backend gl|auto (-1: pick)")
      ->check(CLI::Range(-1, 64));
  bool every_frameset = false;
  app.add_flag("--every-frameset", every_frameset,
               "Step every complete frameset in order, not only the newest (deterministic replays of a recording)");
  CLI11_PARSE(app, argc, argv);
  InstallStopHandler();  // before the models import: SIGINT ends an import too
  try {
    SceneLoadOptions load;
    load.stop = StopRequestFlag();
    if (!scene_path.empty()) spdlog::info("loading {} (and importing its models)", scene_path);
    SceneConfig config = scene_path.empty() ? DefaultScene() : LoadSceneConfig(scene_path, load);
    RigWorld world;  // the Utrecht rig's: up -z, the floor z = 0
    world.floor = RigWorld::Floor::kPlane;
    Aabb workspace;  // none: a stage's origin is the world's, on the floor
    if (!rig_path.empty()) {
      const Rig rig = LoadRig(rig_path);
      world = rig.world;
      workspace = rig.workspace;
    }
    config.PlaceInWorld(world, workspace);
    std::string backend = "cpu";
    if (const auto* models = config.Find<ModelsConfig>()) {
      ModelsConfig m = *models;
      m.threads = model_threads;
      m.query = gl::MakeTriangleQuery(backend_name, gl::EglOptions{gl_device}, &backend, model_threads);
      spdlog::info("CAD models' triangle query: {}", backend);
      config.Set(std::move(m));
    }
    auto participant = StartNode("sim", common);
    WaitSet ws(*participant);
    FramesetInput input(*participant, ws, kFramesetHistory, false, frameset_options);
    Reader<hullpipe_msg_SceneCommand> command_reader(*participant);
    ws.Attach(command_reader);
    SimWriters writers(*participant);
    SystemClock clock;
    nodes::SimController sim(config, clock, input.assembler(), writers);
    sim.set_stop(StopRequestFlag());  // SIGINT ends a long step too
    sim.set_every_frameset(every_frameset);
    sim.set_query_threads(threads > 0 ? threads : std::min(6, ThreadsOrCores(0)));
    sim.counters().SetBackend(backend);
    NodeReporter reporter(*participant, "sim", sim.counters(), common.run_id);
    input.SetCounters(&sim.counters());
    if (frameset_options.input_thread) input.StartInputThread();
    while (!StopRequested()) {
      ws.Wait(0.1);
      input.Poll();
      command_reader.TakeEach([&](const hullpipe_msg_SceneCommand& c, const dds_sample_info_t&) {
        if (c.command == hullpipe_msg_SCENE_COMMAND_SET_SPACING)
          sim.SetSpacing(c.value, c.command_seq);
        else
          sim.RejectCommand(c.command_seq, "unknown command " + std::to_string(c.command));
      });
      sim.SetMalformedInput(input.malformed());
      try {
        sim.Step();
      } catch (const Interrupted& e) {
        spdlog::info("{}; stopping", e.what());
        break;
      }
      reporter.Publish();
    }
    reporter.Publish(true);
    spdlog::info("stopped: {} steps, {} colliding body-steps, {} part collision starts/ends ({} not logged one by "
                 "one), {} dropped, {} rejected",
                 sim.counters().frames_out(), sim.collisions(), sim.part_events(), sim.part_events_unlogged(),
                 sim.counters().dropped(), sim.counters().rejected());
  } catch (const Interrupted& e) {
    spdlog::info("{}; stopped before the first step", e.what());
    return 0;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
