#include "hullpipe/scenes/virtual_scene.h"

#include <stdexcept>

namespace hullpipe {

VirtualScene::VirtualScene(const SceneConfig& config) : config_(config), balls_(config) {
  if (config_.cloth) cloth_.emplace(*config_.cloth, config_.gravity);
  if (config_.particles) particles_.emplace(*config_.particles, config_.gravity, config_.has_floor, config_.floor);
}

SceneStepStats VirtualScene::Step(double dt, const VolumeQuery* hull, StopFlag stop) {
  SceneStepStats st;
  balls_.Step(dt, hull, stop);
  if (cloth_) st.cloth = cloth_->Step(dt, hull, stop);
  if (particles_) st.particles = particles_->Step(dt, hull, stop);
  if (config_.payload) st.payload = EvaluatePayload(*config_.payload, hull);
  return st;
}

void VirtualScene::SetSpacing(double spacing_m) {
  if (!config_.payload) throw std::invalid_argument("this scene has no payload task");
  PayloadConfig c = *config_.payload;
  c.spacing = spacing_m;
  c.Check();
  config_.payload = c;
}

}  // namespace hullpipe
