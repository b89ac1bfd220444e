// sim_node: the virtual scene (paper §4–§5). For every new frameset it steps the
// scene against that frame's visual hull: bounding-box test, then each candidate
// triangle volume-queried in its own viewport; colliding balls bounce, the cloth
// is pushed aside, particles slide off, payload parts report clearance.
// Publishes VirtualObjectState and CollisionReport per ball and frame, and a
// VirtualMesh per cloth, particle stream and payload part. Takes SceneCommand
// (e.g. the payload spacing) while it runs.
#include <CLI/CLI.hpp>
#include <Eigen/Geometry>
#include <spdlog/spdlog.h>

#include "hullpipe/scenes/virtual_scene.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/frameset_input.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/reconstruction/frameset.h"

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
    VirtualScene scene(config);
    const BallSimulation& sim = scene.balls();
    WaitSet ws(*participant);
    FramesetInput input(*participant, ws, 6, false);
    FramesetAssembler& assembler = input.assembler();
    Writer<hullpipe_msg_VirtualObjectState> state_writer(*participant);
    Writer<hullpipe_msg_CollisionReport> report_writer(*participant);
    Writer<hullpipe_msg_VirtualMesh> mesh_writer(*participant);
    Reader<hullpipe_msg_SceneCommand> command_reader(*participant);
    ws.Attach(command_reader);
    NodeReporter reporter(*participant, "sim");
    uint64_t commands_rejected = 0;
    std::vector<bool> part_colliding;  // payload parts colliding in the last frame
    auto publish_mesh = [&](uint32_t id, uint8_t kind, VirtualMeshDraw draw, const Frameset& fs, double clearance) {
      VirtualMeshSample m;
      m.object_id = id;
      m.kind = kind;
      m.frame_seq = fs.seq;
      m.capture_time_ns = fs.capture_time_ns;
      m.draw = std::move(draw);
      m.clearance = clearance;
      mesh_writer.Write(MakeVirtualMeshMessage(m).msg);
    };
    uint64_t collisions = 0;
    // Simulated time follows the frames' source time (not the wall clock), so a
    // run, or a replay of a recording, is deterministic given its inputs.
    double last_source_time = -1;
    spdlog::info("{} ball(s){}{}{}, gravity [{}, {}, {}]", config.balls.size(), config.cloth ? ", a curtain" : "",
                 config.particles ? ", particles" : "", config.payload ? ", the payload task" : "", config.gravity.x(), config.gravity.y(),
                 config.gravity.z());
    while (!StopRequested()) {
      ws.Wait(0.1);
      input.Poll();
      command_reader.TakeEach([&](const hullpipe_msg_SceneCommand& c, const dds_sample_info_t&) {
        try {
          if (c.command != hullpipe_msg_SCENE_COMMAND_SET_SPACING)
            throw std::invalid_argument("unknown command " + std::to_string(c.command));
          if (!std::isfinite(c.value)) throw std::invalid_argument("spacing is not finite");
          scene.SetSpacing(c.value);
          spdlog::info("payload spacing set to {:.1f} cm (command {})", c.value * 100, c.command_seq);
        } catch (const std::exception& e) {
          ++commands_rejected;
          spdlog::warn("SceneCommand {} rejected: {}", c.command_seq, e.what());
        }
      });
      while (auto fs = assembler.TakeNewest()) {
        reporter.FrameIn();
        const double dt = last_source_time < 0 ? 0.0 : fs->source_time_s - last_source_time;
        last_source_time = fs->source_time_s;
        SceneStepStats step;
        {
          StageTimer st(reporter, "step");
          VolumeQuery vq(fs->maps, assembler.workspace());
          step = scene.Step(dt, &vq);
        }
        if (const ClothSimulation* cloth = scene.cloth()) {
          VirtualMeshDraw d;
          const TriangleMesh m = cloth->Mesh();
          d.vertices = m.vertices;
          d.triangles = m.triangles;
          d.colliding = cloth->colliding();
          d.colour = cv::Vec3b(150, 90, 60);
          publish_mesh(uint32_t(cloth->config().id), hullpipe_msg_MESH_KIND_CLOTH, std::move(d), *fs, -1);
        }
        if (const ParticleSystem* ps = scene.particles()) {
          VirtualMeshDraw d;
          d.vertices = ps->positions();
          d.colliding = ps->touching();
          d.colour = cv::Vec3b(230, 160, 60);
          d.point_radius = ps->config().radius;
          publish_mesh(uint32_t(ps->config().id), hullpipe_msg_MESH_KIND_PARTICLES, std::move(d), *fs, -1);
        }
        if (step.payload) {
          const PayloadFrame& pf = *step.payload;
          part_colliding.resize(pf.parts.size(), false);
          for (size_t k = 0; k < pf.parts.size(); ++k) {
            VirtualMeshDraw d;
            const TriangleMesh m = pf.parts[k].Mesh();
            d.vertices = m.vertices;
            d.triangles = m.triangles;
            const bool hit = pf.collisions[k].colliding() || pf.clearance[k].colliding;
            // A part in collision is drawn red whole (§5.2).
            d.colliding.assign(m.triangles.size(), hit ? 1 : 0);
            d.colour = k == 0 ? cv::Vec3b(160, 160, 160) : cv::Vec3b(90, 170, 90);
            publish_mesh(uint32_t(scene.payload()->first_id + int(k)), hullpipe_msg_MESH_KIND_PART, std::move(d),
                         *fs, pf.clearance[k].distance);
            if (hit != part_colliding[k])
              spdlog::info("t={:.3f} s frame {}: {} {} collision (spacing {:.1f} cm)", fs->source_time_s, fs->seq,
                           pf.parts[k].name, hit ? "starts" : "ends", scene.payload()->spacing * 100);
            part_colliding[k] = hit;
          }
          spdlog::debug("frame {} clearance mm: PMT {:.1f}, payload A {:.1f}, shaft {:.1f}", fs->seq,
                        pf.clearance[0].distance * 1e3, pf.clearance[1].distance * 1e3,
                        pf.clearance[2].distance * 1e3);
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
          Borrow(&r.triangle_ids, ids);
          Borrow(&r.collision_points, points);
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
      reporter.SetRejected(input.rejected() + commands_rejected);
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
