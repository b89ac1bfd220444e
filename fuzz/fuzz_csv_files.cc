// libFuzzer: the CSV files hullpipe reads: head-pose logs (geometry/head_pose.h,
// render_node --head-poses, a tracked camera's `tracked`), pipe motions
// (scenes/payload.h, the payload task) and an HMD runtime's per-eye views
// (reconstruction/stereo_views.h, render_node --eye-views). The first byte
// picks the parser. A bad file must end in std::runtime_error naming the file
// and line; a track that loads answers At() for any time with a finite rigid
// transform (and each eye a finite view).
#include <cmath>
#include <stdexcept>

#include "fuzz_util.h"
#include "hullpipe/geometry/head_pose.h"
#include "hullpipe/reconstruction/stereo_views.h"
#include "hullpipe/scenes/payload.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  hullpipe::fuzz::InputFile file(data + 1, size - 1, ".csv");
  try {
    if (data[0] % 3 == 0) {
      const hullpipe::PoseTrack track = hullpipe::LoadPoseTrack(file.path());
      for (double t : {-1e9, 0.0, 0.5, 1e9}) {
        const hullpipe::Rigid3d p = track.At(t);
        if (!p.rotation.allFinite() || !p.translation.allFinite()) __builtin_trap();
      }
    } else if (data[0] % 3 == 1) {
      hullpipe::LoadPipeMotion(file.path());
    } else {
      const hullpipe::StereoViewTrack track = hullpipe::LoadStereoViewTrack(file.path());
      for (double t : {-1e9, 0.0, 0.5, 1e9})
        for (const hullpipe::Eye e : {hullpipe::Eye::kLeft, hullpipe::Eye::kRight}) {
          const hullpipe::NovelView v = track.At(t, e, 64, 48);
          if (!v.world_from_eye.rotation.allFinite() || !v.world_from_eye.translation.allFinite() ||
              !std::isfinite(v.fx) || !std::isfinite(v.fy) || !std::isfinite(v.cx) || !std::isfinite(v.cy))
            __builtin_trap();
        }
    }
  } catch (const std::runtime_error&) {
  }
  return 0;
}
