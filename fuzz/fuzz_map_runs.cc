// libFuzzer: object-pixel map run-length decoding (segmentation/object_pixel_map.h),
// as a received ObjectPixelMap gives it: any width, height and runs. Input:
// width (int32 LE), height (int32 LE), then uint32 LE runs. Checks beyond "no
// crash": a decoded map has the size asked for, and encoding it again gives
// runs that decode to the same map.
#include <cstring>
#include <vector>

#include "hullpipe/segmentation/object_pixel_map.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 8) return 0;
  int32_t width, height;
  std::memcpy(&width, data, 4);
  std::memcpy(&height, data + 4, 4);
  std::vector<uint32_t> runs((size - 8) / 4);
  if (!runs.empty()) std::memcpy(runs.data(), data + 8, runs.size() * 4);
  cv::Mat map;
  try {
    map = hullpipe::RunLengthDecode(runs, width, height);
  } catch (const hullpipe::MapDecodeError&) {
    return 0;  // refused, as the nodes do (counted, one line)
  }
  if (map.cols != width || map.rows != height || map.type() != CV_8UC1) __builtin_trap();
  // The encoder round trip on maps up to 4 Mpixel (any rig camera): a
  // 201-Mpixel map (16384x12288, legal) took 15 s to re-encode under the
  // sanitizers and coverage, a libFuzzer time-out of the check, not of the
  // decoder (nodes now check a map's size against the calibration first).
  if (int64_t(width) * height > (int64_t(1) << 22)) return 0;
  const cv::Mat again = hullpipe::RunLengthDecode(hullpipe::RunLengthEncode(map), width, height);
  if (cv::countNonZero(again != map) != 0) __builtin_trap();
  return 0;
}
