// libFuzzer: rig calibration files (geometry/calibration.h, rig_import.h).
// The first byte picks the parser, by its value modulo 3: 0, a Utrecht
// config.xml (OpenCV FileStorage) read by ReadOpenCvCameraConfig; 1, a YAML rig
// file read by LoadRig; 2, an OpenCV calibration (multi-camera, stereo, XML or
// YAML) read by ImportOpenCvYaml. Every bad file must end in CalibrationError
// (file and key named), nothing else; a camera that loads passes Camera::Check.
#include "fuzz_util.h"
#include "hullpipe/geometry/calibration.h"
#include "hullpipe/geometry/rig_import.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const int parser = data[0] % 3;
  hullpipe::fuzz::InputFile file(data + 1, size - 1,
                                 parser == 0   ? "_config.xml"
                                 : parser == 1 ? "_rig.yaml"
                                               : "_calib.yml");
  try {
    if (parser == 0) {
      hullpipe::ReadOpenCvCameraConfig(file.path(), 1, 644, 486).Check();
    } else if (parser == 1) {
      for (const auto& c : hullpipe::LoadRig(file.path()).cameras) c.camera.Check();
    } else {
      hullpipe::ImportOptions o;
      o.width = 640;
      o.height = 480;
      for (const auto& c : hullpipe::ImportOpenCvYaml(file.path(), o).cameras) c.camera.Check();
    }
  } catch (const hullpipe::CalibrationError&) {
  }
  return 0;
}
