#include "hullpipe/nodes/sim_controller.h"

#include <cmath>
#include <stdexcept>

#include <spdlog/spdlog.h>

namespace hullpipe::nodes {

SimController::SimController(SceneConfig scene, const Clock& clock, FramesetAssembler& assembler, SimSink& sink)
    : assembler_(assembler), sink_(sink), scene_((scene.Check(), scene)), counters_(clock) {
  spdlog::info("{}", scene_.Describe());
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
  {
    StageTimer st(counters_, "step");
    VolumeQuery vq(fs.maps, assembler_.workspace());
    spdlog::debug("frameset {}: stepping the scene {:.3f} s", fs.seq, dt);
    scene_.Step(dt, &vq, stop_);
  }
  StageTimer publish_timer(counters_, "publish");
  ElementOutput out = scene_.Output(fs.source_time_s, fs.seq);
  for (const ModelPartSample& p : out.model_parts) sink_.PublishModelPart(p);
  for (ModelStateSample& m : out.model_states) {
    m.frame_seq = fs.seq;
    m.capture_time_ns = fs.capture_time_ns;
    counters_.Stage("models", m.query_ms);
    sink_.PublishModelState(m);
  }
  for (VirtualMeshSample& m : out.meshes) {
    m.frame_seq = fs.seq;
    m.capture_time_ns = fs.capture_time_ns;
    sink_.PublishMesh(m);
  }
  for (VirtualObjectSample& s : out.states) {
    s.frame_seq = fs.seq;
    s.capture_time_ns = fs.capture_time_ns;
    sink_.PublishState(s);
  }
  for (CollisionReportSample& r : out.reports) {
    r.frame_seq = fs.seq;
    r.capture_time_ns = fs.capture_time_ns;
    sink_.PublishReport(r);
  }
  collisions_ += out.colliding_bodies;
  for (const PartCollisionEvent& e : out.events) {
    spdlog::info("t={:.3f} s frame {}: {} {} collision (spacing {:.1f} cm)", e.source_time_s, e.frame_seq, e.part,
                 e.starts ? "starts" : "ends", e.spacing_m * 100);
    part_events_.push_back(e);
  }
  counters_.FrameOut(fs.capture_time_ns);
}

}  // namespace hullpipe::nodes
