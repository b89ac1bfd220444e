// libFuzzer: model files (models/model_import.h), as a scene's `models` entry
// loads them. The first byte picks the format (glb, gltf, obj, stl, ply, off,
// dae, fbx); the rest is the file. Every input must end in a model or one
// ModelError: Assimp runs in ImportModel's bounded child process (2 s here), so
// a crash, hang or huge allocation inside Assimp is a ModelError, not a
// finding. Half the inputs (the first byte's top bit) go instead to
// DeserializeModel, the parent's reading of the child's result, in process.
#include <string>

#include "fuzz_util.h"
#include "hullpipe/models/model_import.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  static const char* kExt[8] = {".glb", ".gltf", ".obj", ".stl", ".ply", ".off", ".dae", ".fbx"};
  hullpipe::ImportLimits limits;
  limits.max_seconds = 2;
  limits.max_memory_bytes = int64_t(512) << 20;
  limits.max_triangles = 200000;
  try {
    if (data[0] & 0x80) {
      hullpipe::DeserializeModel(std::string(reinterpret_cast<const char*>(data + 1), size - 1), "input", limits);
    } else {
      hullpipe::fuzz::InputFile file(data + 1, size - 1, std::string("_model") + kExt[data[0] & 7]);
      hullpipe::ImportModel(file.path(), limits);
    }
  } catch (const hullpipe::ModelError&) {
  }
  return 0;
}
