#include "hullpipe/virtual_scene.h"

#include <stdexcept>

namespace hullpipe {

VirtualScene::VirtualScene(const SceneConfig& config) : config_(config), balls_(config), payload_(config.payload) {
  if (config_.cloth) cloth_.emplace(*config_.cloth, config_.gravity);
  if (config_.particles) particles_.emplace(*config_.particles, config_.gravity, config_.has_floor, config_.floor);
}

SceneStepStats VirtualScene::Step(double dt, const VolumeQuery* hull) {
  SceneStepStats st;
  balls_.Step(dt, hull);
  if (cloth_) st.cloth = cloth_->Step(dt, hull);
  if (particles_) st.particles = particles_->Step(dt, hull);
  if (payload_) st.payload = EvaluatePayload(*payload_, hull);
  return st;
}

void VirtualScene::SetSpacing(double spacing_m) {
  if (!payload_) throw std::invalid_argument("this scene has no payload task");
  PayloadConfig c = *payload_;
  c.spacing = spacing_m;
  c.Check();
  payload_ = c;
}

}  // namespace hullpipe
