// Everything sim_node simulates against the visual hull (paper §4–§5):
// the thrown balls (ball.h), an optional cloth curtain (cloth.h), an
// optional particle stream (particles.h) and the optional payload spacing task
// (payload.h), stepped together, deterministically, frame by frame.
#pragma once

#include <optional>

#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/scenes/ball.h"

namespace hullpipe {

/// What one step did, per part of the scene.
struct SceneStepStats {
  ClothStepStats cloth;
  ParticleStepStats particles;
  std::optional<PayloadFrame> payload;  ///< The task's collisions and clearances.
};

class VirtualScene {
 public:
  /// Throws std::invalid_argument if the config fails Check().
  explicit VirtualScene(const SceneConfig& config);
  /// Advances every part by dt seconds against `hull` (nullptr: none). Throws
  /// Interrupted (util/interrupt.h) between substeps once `stop` is set; the
  /// scene is then part-way through the step (good only for stopping).
  SceneStepStats Step(double dt, const VolumeQuery* hull, StopFlag stop = nullptr);
  const BallSimulation& balls() const { return balls_; }
  const ClothSimulation* cloth() const { return cloth_ ? &*cloth_ : nullptr; }
  const ParticleSystem* particles() const { return particles_ ? &*particles_ : nullptr; }
  /// The payload task's settings, if any (spacing as last set; config() agrees).
  const std::optional<PayloadConfig>& payload() const { return config_.payload; }
  /// Changes the PMT-to-payload-A spacing while running (paper §5.2). Throws
  /// std::invalid_argument (nothing changes) if there is no payload task or the
  /// spacing fails PayloadConfig::Check().
  void SetSpacing(double spacing_m);
  const SceneConfig& config() const { return config_; }

 private:
  SceneConfig config_;
  BallSimulation balls_;
  std::optional<ClothSimulation> cloth_;
  std::optional<ParticleSystem> particles_;
};

}  // namespace hullpipe
