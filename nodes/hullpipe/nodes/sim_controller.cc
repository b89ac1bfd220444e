#include "hullpipe/nodes/sim_controller.h"

#include <algorithm>
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
  reject_log_.Log("SceneCommand " + std::to_string(command_seq) + ": " + why, counters_.clock().Now());
}

int SimController::Step() {
  int stepped = 0;
  while (auto fs = every_frameset_ ? assembler_.TakeOldest() : assembler_.TakeNewest()) {
    StepOne(*fs);
    ++stepped;
  }
  counters_.SetDropped(assembler_.dropped());
  counters_.SetAssembly(assembler_.SkewReports(), assembler_.dropped_for_skew());
  counters_.SetRejected(assembler_.rejected() + assembler_.calibrations_refused() + commands_rejected_ +
                        malformed_input_);
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
    auto vq = std::make_unique<VolumeQuery>(fs.maps, assembler_.workspace(), query_options_);
    // The hull's motion since the previous frameset stepped (hull_motion.h):
    // that one's hull is kept; an older one, a changed rig or a later time
    // gives no velocity (HullMotion says which). Timed on the clock the scene
    // steps by, the frames' source time (a live camera's capture time; a
    // file's own timeline, also when capture paces it slower), each map offset
    // by its capture-time skew from the reference camera's.
    TimedHull current = TimedHull::Of(*vq, int64_t(std::llround(fs.source_time_s * 1e9)), fs.skew_ns);
    const HullMotionOptions& mo = scene_.config().hull_velocity;
    std::unique_ptr<HullMotion> motion;
    if (mo.enabled) motion = std::make_unique<HullMotion>(current, previous_hull_, mo);
    spdlog::debug("frameset {}: stepping the scene {:.3f} s", fs.seq, dt);
    scene_.Step({.dt = dt, .hull = vq.get(), .hull_motion = motion.get(), .stop = stop_});
    motion.reset();
    previous_query_ = std::move(vq);
    previous_hull_ = std::move(current);  // points at *previous_query_, which moved with its pointer
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
    if (r.has_response && r.hull_velocity_status < hull_velocity_counts_.size()) {
      if (r.hull_velocity_status == uint8_t(HullVelocityStatus::kClamped) &&
          hull_velocity_counts_[r.hull_velocity_status] == 0)
        spdlog::warn("frame {}: object {} was struck by a hull surface faster than hull_velocity.max_speed ({} m/s): "
                     "clamped, and counted from here on (the scene's hull_velocity.max_speed sets the bound)",
                     fs.seq, r.object_id, scene_.config().hull_velocity.max_speed);
      ++hull_velocity_counts_[r.hull_velocity_status];
    }
    r.frame_seq = fs.seq;
    r.capture_time_ns = fs.capture_time_ns;
    sink_.PublishReport(r);
  }
  collisions_ += out.colliding_bodies;
  // Part events at a bounded rate (a token bucket on source time).
  part_event_tokens_ = std::min(
      kPartEventBurst, part_event_tokens_ + std::max(0.0, fs.source_time_s - part_event_time_s_) * kPartEventLinesPerS);
  part_event_time_s_ = fs.source_time_s;
  for (const PartCollisionEvent& e : out.events) {
    ++part_events_;
    if (part_event_tokens_ >= 1 && part_events_pending_ == 0) {
      part_event_tokens_ -= 1;
      spdlog::info("t={:.3f} s frame {}: {} {} collision (spacing {:.1f} cm)", e.source_time_s, e.frame_seq, e.part,
                   e.starts ? "starts" : "ends", e.spacing_m * 100);
    } else {
      ++part_events_unlogged_;
      ++part_events_pending_;
    }
  }
  if (part_events_pending_ > 0 && part_event_tokens_ >= 1) {
    part_event_tokens_ -= 1;
    spdlog::info("t={:.3f} s frame {}: {} more part collision start(s)/end(s) not logged one by one (at most {} "
                 "lines a second); {} in all so far",
                 fs.source_time_s, fs.seq, part_events_pending_, kPartEventLinesPerS, part_events_);
    part_events_pending_ = 0;
  }
  counters_.FrameOut(fs.capture_time_ns);
}

}  // namespace hullpipe::nodes
