// The registry of scene element kinds (scene_element.h): one line per kind.
// A new kind is its module (settings, reader, simulation) and a line here.
#include "hullpipe/scenes/ball.h"
#include "hullpipe/scenes/cloth.h"
#include "hullpipe/scenes/model_scene.h"
#include "hullpipe/scenes/particles.h"
#include "hullpipe/scenes/payload.h"
#include "hullpipe/scenes/scene_element.h"

namespace hullpipe {

const std::vector<SceneElementKind>& SceneElementKinds() {
  static const std::vector<SceneElementKind> kinds = {
      {"balls", [](const auto& n, const auto& path, const auto&) { return ReadBallsSection(n, path); }, true},
      {"cloth", [](const auto& n, const auto& path, const auto&) { return ReadClothSection(n, path); }},
      {"particles", [](const auto& n, const auto& path, const auto&) { return ReadParticlesSection(n, path); }},
      {"payload", ReadPayloadSection},
      {"models", ReadModelsSection},
  };
  return kinds;
}

SceneConfig DefaultScene() {
  SceneConfig scene;
  scene.Set(BallsConfig({BallConfig{}}));
  return scene;
}

}  // namespace hullpipe
