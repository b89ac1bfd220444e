// libFuzzer: scene files (scenes/scene_config.h), as sim_node and render_node
// read them. A bad file must end in std::runtime_error naming the file and key
// (LoadSceneConfig's contract); a scene that loads passes its own Check.
#include <stdexcept>

#include "fuzz_util.h"
#include "hullpipe/scenes/scene_config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  hullpipe::fuzz::InputFile file(data, size, "_scene.yaml");
  try {
    hullpipe::LoadSceneConfig(file.path(), hullpipe::SceneLoadOptions{false}).Check();
  } catch (const std::runtime_error&) {
  }
  return 0;
}
