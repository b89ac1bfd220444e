// Everything sim_node simulates against the visual hull (paper §4–§5): every
// element of the scene file (the thrown balls, cloth, particles, the payload
// task, CAD models: scene_element.h), stepped together, deterministically,
// frame by frame.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "hullpipe/scenes/ball.h"
#include "hullpipe/scenes/payload.h"
#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/scenes/scene_element.h"

namespace hullpipe {

class VirtualScene {
 public:
  /// Throws std::invalid_argument if the config fails Check().
  explicit VirtualScene(const SceneConfig& config);
  /// Advances every element, in the registry's order, by step.dt against step.hull
  /// (scene_element.h StepContext: nullptr, none; its motion since the previous
  /// frameset, given to every element). Throws Interrupted (util/interrupt.h)
  /// once step.stop is set; the scene is then part-way through the step (good
  /// only for stopping).
  void Step(const StepContext& step);
  /// The same, its context given field by field.
  void Step(double dt, const VolumeQuery* hull, StopFlag stop = nullptr, const HullMotion* motion = nullptr) {
    Step(StepContext{.dt = dt, .hull = hull, .hull_motion = motion, .stop = stop});
  }
  /// What every element gives to publish after the last step, in the
  /// registry's order (their frame_seq and capture_time_ns left for the caller).
  ElementOutput Output(double source_time_s, uint64_t frame_seq);
  /// The balls' simulation, or nullptr when the scene has no `balls`.
  const BallSimulation* balls() const { return balls_ ? &balls_->simulation() : nullptr; }
  /// The payload task's settings, if any (spacing as last set; config() agrees).
  const PayloadConfig* payload() const { return config_.Find<PayloadConfig>(); }
  /// Changes the PMT-to-payload-A spacing while running (paper §5.2). Throws
  /// std::invalid_argument (nothing changes) if there is no payload task or the
  /// spacing fails PayloadConfig::Check().
  void SetSpacing(double spacing_m);
  const SceneConfig& config() const { return config_; }
  /// "2 ball(s), a curtain, gravity [0, 0, 9.81]": what the scene holds (each
  /// element's Describe), for the log.
  std::string Describe() const;

 private:
  SceneConfig config_;
  std::vector<std::unique_ptr<SceneElement>> elements_;  ///< As config_.elements.
  const BallsElement* balls_ = nullptr;
};

}  // namespace hullpipe
