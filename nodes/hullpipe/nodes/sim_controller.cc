#include "hullpipe/nodes/sim_controller.h"

#include <cmath>
#include <stdexcept>

#include <spdlog/spdlog.h>

namespace hullpipe::nodes {

SimController::SimController(SceneConfig scene, const Clock& clock, FramesetAssembler& assembler, SimSink& sink)
    : assembler_(assembler), sink_(sink), scene_((scene.Check(), scene)), counters_(clock) {
  const SceneConfig& c = scene_.config();
  spdlog::info("{} ball(s){}{}{}, gravity [{}, {}, {}]", c.balls.size(), c.cloth ? ", a curtain" : "",
               c.particles ? ", particles" : "", c.payload ? ", the payload task" : "", c.gravity.x(), c.gravity.y(),
               c.gravity.z());
}

bool SimController::SetSpacing(double spacing_m, uint64_t command_seq) {
  try {
    if (!std::isfinite(spacing_m)) throw std::invalid_argument("spacing is not finite");
    scene_.SetSpacing(spacing_m);
    spdlog::info("payload spacing set to {:.1f} cm (command {})", spacing_m * 100, command_seq);
    return true;
  } catch (const std::exception& e) {
    RejectCommand(command_seq, e.what());
    return false;
  }
}

void SimController::RejectCommand(uint64_t command_seq, const std::string& why) {
  ++commands_rejected_;
  spdlog::warn("SceneCommand {} rejected: {}", command_seq, why);
}

int SimController::Step() {
  int stepped = 0;
  while (auto fs = every_frameset_ ? assembler_.TakeOldest() : assembler_.TakeNewest()) {
    StepOne(*fs);
    ++stepped;
  }
  counters_.SetDropped(assembler_.dropped());
  counters_.SetAssembly(assembler_.SkewReports(), assembler_.dropped_for_skew());
  counters_.SetRejected(assembler_.rejected() + commands_rejected_ + malformed_input_);
  return stepped;
}

void SimController::StepOne(const Frameset& fs) {
  counters_.FrameIn();
  // The budget's sim stages (docs/latency.md): wait, step, publish.
  counters_.StageSince("wait", fs.last_arrival_ns);
  // Simulated time follows the frames' source time (not the wall clock).
  const double dt = last_source_time_ < 0 ? 0.0 : fs.source_time_s - last_source_time_;
  last_source_time_ = fs.source_time_s;
  SceneStepStats step;
  {
    StageTimer st(counters_, "step");
    VolumeQuery vq(fs.maps, assembler_.workspace());
    spdlog::debug("frameset {}: stepping the scene {:.3f} s", fs.seq, dt);
    step = scene_.Step(dt, &vq, stop_);
  }
  StageTimer publish_timer(counters_, "publish");
  auto mesh = [&](uint32_t id, uint8_t kind, VirtualMeshDraw draw, double clearance) {
    VirtualMeshSample m;
    m.object_id = id;
    m.kind = kind;
    m.frame_seq = fs.seq;
    m.capture_time_ns = fs.capture_time_ns;
    m.draw = std::move(draw);
    m.clearance = clearance;
    sink_.PublishMesh(m);
  };
  if (const ClothSimulation* cloth = scene_.cloth()) {
    VirtualMeshDraw d;
    const TriangleMesh m = cloth->Mesh();
    d.vertices = m.vertices;
    d.triangles = m.triangles;
    d.colliding = cloth->colliding();
    d.colour = cv::Vec3b(150, 90, 60);
    mesh(uint32_t(cloth->config().id), kMeshCloth, std::move(d), -1);
  }
  if (const ParticleSystem* ps = scene_.particles()) {
    VirtualMeshDraw d;
    d.vertices = ps->positions();
    d.colliding = ps->touching();
    d.colour = cv::Vec3b(230, 160, 60);
    d.point_radius = ps->config().radius;
    mesh(uint32_t(ps->config().id), kMeshParticles, std::move(d), -1);
  }
  if (step.payload) {
    const PayloadFrame& pf = *step.payload;
    part_colliding_.resize(pf.parts.size(), false);
    for (size_t k = 0; k < pf.parts.size(); ++k) {
      VirtualMeshDraw d;
      const TriangleMesh m = pf.parts[k].Mesh();
      d.vertices = m.vertices;
      d.triangles = m.triangles;
      const bool hit = pf.collisions[k].colliding() || pf.clearance[k].colliding;
      // A part in collision is drawn red whole (§5.2).
      d.colliding.assign(m.triangles.size(), hit ? 1 : 0);
      d.colour = k == 0 ? cv::Vec3b(160, 160, 160) : cv::Vec3b(90, 170, 90);
      mesh(uint32_t(scene_.payload()->first_id + int(k)), kMeshPart, std::move(d), pf.clearance[k].distance);
      if (hit != part_colliding_[k]) {
        part_events_.push_back({fs.source_time_s, fs.seq, pf.parts[k].name, hit, scene_.payload()->spacing});
        spdlog::info("t={:.3f} s frame {}: {} {} collision (spacing {:.1f} cm)", fs.source_time_s, fs.seq,
                     pf.parts[k].name, hit ? "starts" : "ends", scene_.payload()->spacing * 100);
      }
      part_colliding_[k] = hit;
    }
    spdlog::debug("frame {} clearance mm: PMT {:.1f}, payload A {:.1f}, shaft {:.1f}", fs.seq,
                  pf.clearance[0].distance * 1e3, pf.clearance[1].distance * 1e3, pf.clearance[2].distance * 1e3);
  }
  const BallSimulation& sim = scene_.balls();
  for (const BodyState& b : sim.bodies()) {
    VirtualObjectSample s;
    s.object_id = uint32_t(b.id);
    s.frame_seq = fs.seq;
    s.capture_time_ns = fs.capture_time_ns;
    s.sim_time = sim.time();
    s.radius = b.radius;
    s.position = b.position;
    s.velocity = b.velocity;
    s.colliding = b.colliding;
    sink_.PublishState(s);

    CollisionReportSample r;
    r.object_id = uint32_t(b.id);
    r.frame_seq = fs.seq;
    r.capture_time_ns = fs.capture_time_ns;
    if (b.colliding) {
      ++collisions_;
      for (int t : b.last_collision.triangle_ids) r.triangle_ids.push_back(uint32_t(t));
      r.collision_points = b.last_collision.collision_points;
    }
    r.has_response = b.colliding && b.last_response.has_value();
    if (r.has_response) {
      const CollisionResponse& resp = *b.last_response;
      r.cp_obj = resp.cp_obj;
      r.cp_hull = resp.cp_hull;
      r.v_rec = resp.v_rec;
      r.d_rec = resp.d_rec;
      r.n_hull = resp.n_hull;
    }
    sink_.PublishReport(r);
  }
  counters_.FrameOut(fs.capture_time_ns);
}

}  // namespace hullpipe::nodes
