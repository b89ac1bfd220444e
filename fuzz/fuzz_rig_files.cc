// libFuzzer: rig calibration files (geometry/calibration.h). The first byte
// picks the parser: even, a Utrecht config.xml (OpenCV FileStorage) read by
// ReadOpenCvCameraConfig; odd, a YAML rig file read by LoadRig. Every bad file
// must end in CalibrationError (file and key named), nothing else; a camera
// that loads passes Camera::Check.
#include "fuzz_util.h"
#include "hullpipe/geometry/calibration.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const bool xml = data[0] % 2 == 0;
  hullpipe::fuzz::InputFile file(data + 1, size - 1, xml ? "_config.xml" : "_rig.yaml");
  try {
    if (xml) {
      hullpipe::ReadOpenCvCameraConfig(file.path(), 1, 644, 486).Check();
    } else {
      for (const auto& c : hullpipe::LoadRig(file.path()).cameras) c.camera.Check();
    }
  } catch (const hullpipe::CalibrationError&) {
  }
  return 0;
}
