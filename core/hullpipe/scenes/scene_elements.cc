// The registry of scene element kinds (scene_element.h): one line per kind.
// A new kind is its module (settings, reader, simulation) and a line here.
#include "hullpipe/scenes/cloth.h"
#include "hullpipe/scenes/particles.h"
#include "hullpipe/scenes/payload.h"
#include "hullpipe/scenes/scene_element.h"

namespace hullpipe {

const std::vector<SceneElementKind>& SceneElementKinds() {
  static const std::vector<SceneElementKind> kinds = {
      {"cloth", ReadClothSection},
      {"particles", ReadParticlesSection},
      {"payload", ReadPayloadSection},
  };
  return kinds;
}

}  // namespace hullpipe
