// libFuzzer: the CSV files hullpipe reads: head-pose logs (geometry/head_pose.h,
// render_node --head-poses, a tracked camera's `tracked`) and pipe motions
// (scenes/payload.h, the payload task). The first byte picks the parser. A bad
// file must end in std::runtime_error naming the file and line; a track that
// loads answers At() for any time with a finite rigid transform.
#include <cmath>
#include <stdexcept>

#include "fuzz_util.h"
#include "hullpipe/geometry/head_pose.h"
#include "hullpipe/scenes/payload.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  hullpipe::fuzz::InputFile file(data + 1, size - 1, ".csv");
  try {
    if (data[0] % 2 == 0) {
      const hullpipe::PoseTrack track = hullpipe::LoadPoseTrack(file.path());
      for (double t : {-1e9, 0.0, 0.5, 1e9}) {
        const hullpipe::Rigid3d p = track.At(t);
        if (!p.rotation.allFinite() || !p.translation.allFinite()) __builtin_trap();
      }
    } else {
      hullpipe::LoadPipeMotion(file.path());
    }
  } catch (const std::runtime_error&) {
  }
  return 0;
}
