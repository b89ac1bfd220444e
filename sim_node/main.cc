// sim_node: the virtual scene (paper §4). For every new frameset it steps the
// simulation against that frame's visual hull: bounding-box test, then each
// candidate triangle volume-queried in its own viewport; colliding balls bounce.
// Publishes VirtualObjectState and CollisionReport per object and frame.
#include <CLI/CLI.hpp>
#include <Eigen/Geometry>
#include <spdlog/spdlog.h>

#include "hullpipe/ball_scene.h"
#include "hullpipe/conventions.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/frameset_input.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/frameset.h"

using namespace hullpipe;
using namespace hullpipe::dds;

int main(int argc, char** argv) {
  CLI::App app{"hullpipe sim_node: virtual scene colliding with the visual hull"};
  CommonOptions common;
  AddCommonOptions(app, common);
  std::string scene_path;
  app.add_option("--scene", scene_path, "Scene file (YAML); default: one ball");
  CLI11_PARSE(app, argc, argv);
  try {
    const SceneConfig config = scene_path.empty() ? SceneConfig{} : LoadSceneConfig(scene_path);
    auto participant = StartNode("sim", common);
    BallSimulation sim(config);
    WaitSet ws(*participant);
    FramesetInput input(*participant, ws, 6, false);
    FramesetAssembler& assembler = input.assembler();
    Writer<hullpipe_msg_VirtualObjectState> state_writer(*participant);
    Writer<hullpipe_msg_CollisionReport> report_writer(*participant);
    NodeReporter reporter(*participant, "sim");
    uint64_t collisions = 0;
    // Simulated time follows the frames' source time (not the wall clock), so a
    // run, or a replay of a recording, is deterministic given its inputs.
    double last_source_time = -1;
    spdlog::info("{} ball(s), gravity [{}, {}, {}]", config.balls.size(), config.gravity.x(), config.gravity.y(),
                 config.gravity.z());
    while (!StopRequested()) {
      ws.Wait(0.1);
      input.Poll();
      while (auto fs = assembler.TakeNewest()) {
        reporter.FrameIn();
        const double dt = last_source_time < 0 ? 0.0 : fs->source_time_s - last_source_time;
        last_source_time = fs->source_time_s;
        {
          StageTimer st(reporter, "step");
          VolumeQuery vq(fs->maps, assembler.workspace());
          sim.Step(dt, &vq);
        }
        for (const BodyState& b : sim.bodies()) {
          hullpipe_msg_VirtualObjectState s{};
          s.object_id = uint32_t(b.id);
          s.frame_seq = fs->seq;
          s.capture_time_ns = fs->capture_time_ns;
          s.sim_time = sim.time();
          s.shape = hullpipe_msg_SHAPE_SPHERE;
          s.radius = b.radius;
          s.position = ToMsg(b.position);
          s.velocity = ToMsg(b.velocity);
          s.orientation[0] = 1;
          s.colliding = b.colliding;
          state_writer.Write(s);

          std::vector<uint32_t> ids;
          std::vector<hullpipe_msg_Vec3> points;
          if (b.colliding) {
            ++collisions;
            for (int t : b.last_collision.triangle_ids) ids.push_back(uint32_t(t));
            for (const auto& p : b.last_collision.collision_points) points.push_back(ToMsg(p));
          }
          hullpipe_msg_CollisionReport r{};
          r.object_id = uint32_t(b.id);
          r.frame_seq = fs->seq;
          r.capture_time_ns = fs->capture_time_ns;
          r.triangle_ids._buffer = ids.data();
          r.triangle_ids._length = r.triangle_ids._maximum = uint32_t(ids.size());
          r.collision_points._buffer = points.data();
          r.collision_points._length = r.collision_points._maximum = uint32_t(points.size());
          r.has_response = b.colliding && b.last_response.has_value();
          if (r.has_response) {
            const CollisionResponse& resp = *b.last_response;
            r.cp_obj = ToMsg(resp.cp_obj);
            r.cp_hull = ToMsg(resp.cp_hull);
            r.v_rec = ToMsg(resp.v_rec);
            r.d_rec = resp.d_rec;
            r.n_hull = ToMsg(resp.n_hull);
          }
          report_writer.Write(r);
        }
        reporter.FrameOut(fs->capture_time_ns);
      }
      reporter.SetDropped(input.dropped());
      reporter.SetRejected(input.rejected());
      reporter.Publish();
    }
    reporter.Publish(true);
    spdlog::info("stopped: {} steps, {} colliding body-steps, {} dropped, {} rejected", reporter.frames_out(),
                 collisions, reporter.dropped(), reporter.rejected());
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
