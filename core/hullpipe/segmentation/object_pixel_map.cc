#include "hullpipe/segmentation/object_pixel_map.h"

#include <string>

#include <opencv2/imgproc.hpp>

namespace hullpipe {

std::vector<uint32_t> RunLengthEncode(const cv::Mat& map) {
  CV_Assert(map.type() == CV_8UC1);
  std::vector<uint32_t> runs;
  runs.reserve(64);
  bool current = false;  // runs start with background
  uint32_t length = 0;
  for (int r = 0; r < map.rows; ++r) {
    const uint8_t* row = map.ptr<uint8_t>(r);
    for (int c = 0; c < map.cols; ++c) {
      const bool obj = row[c] != 0;
      if (obj != current) {
        runs.push_back(length);
        length = 0;
        current = obj;
      }
      ++length;
    }
  }
  runs.push_back(length);
  return runs;
}

cv::Mat RunLengthDecode(const uint32_t* runs, size_t count, int width, int height) {
  if (width <= 0 || height <= 0 || width > 16384 || height > 16384)
    throw MapDecodeError("object-pixel map size " + std::to_string(width) + "x" +
                         std::to_string(height) + " is out of range");
  const uint64_t total = uint64_t(width) * uint64_t(height);
  uint64_t sum = 0;
  for (size_t i = 0; i < count; ++i) sum += runs[i];
  if (sum != total)
    throw MapDecodeError("object-pixel map runs sum to " + std::to_string(sum) +
                         " pixels, expected " + std::to_string(total));
  cv::Mat map(height, width, CV_8UC1);
  uint8_t* out = map.ptr<uint8_t>(0);  // freshly allocated: continuous
  uint8_t value = 0;
  for (size_t i = 0; i < count; ++i) {
    std::fill(out, out + runs[i], value);
    out += runs[i];
    value = value ? 0 : 255;
  }
  return map;
}

cv::Mat RunLengthDecode(const std::vector<uint32_t>& runs, int width, int height) {
  return RunLengthDecode(runs.data(), runs.size(), width, height);
}

cv::Rect ObjectBoundingRect(const cv::Mat& map) {
  CV_Assert(map.type() == CV_8UC1);
  return cv::boundingRect(map);
}

}  // namespace hullpipe
