#include "hullpipe/scenes/virtual_scene.h"

#include <sstream>
#include <stdexcept>

namespace hullpipe {

VirtualScene::VirtualScene(const SceneConfig& config) : config_(config) {
  config_.Check();
  for (const auto& e : config_.elements) {
    elements_.push_back(e->Make(config_));
    if (const auto* b = dynamic_cast<const BallsElement*>(elements_.back().get())) balls_ = b;
  }
}

void VirtualScene::Step(const StepContext& step) {
  for (auto& e : elements_) e->Step(step);
}

ElementOutput VirtualScene::Output(double source_time_s, uint64_t frame_seq) {
  ElementOutput out;
  for (size_t i = 0; i < elements_.size(); ++i) {
    const size_t before = out.meshes.size();
    elements_[i]->Output(source_time_s, frame_seq, &out);
    // Each mesh names its element, for what render_node reports per element.
    for (size_t k = before; k < out.meshes.size(); ++k) out.meshes[k].element = config_.elements[i]->Key();
  }
  return out;
}

void VirtualScene::SetSpacing(double spacing_m) {
  const PayloadConfig* current = payload();
  if (!current) throw std::invalid_argument("this scene has no payload task");
  PayloadConfig c = *current;
  c.spacing = spacing_m;
  c.Check();
  for (auto& e : elements_) e->SetSpacing(spacing_m);
  config_.Set(std::move(c));
}

std::string VirtualScene::Describe() const {
  std::string s;
  for (const auto& e : config_.elements) s += (s.empty() ? "" : ", ") + e->Describe();
  if (s.empty()) s = "nothing";
  std::ostringstream g;
  g << ", gravity [" << config_.gravity.x() << ", " << config_.gravity.y() << ", " << config_.gravity.z() << "]";
  return s + g.str();
}

}  // namespace hullpipe
