#include "hullpipe/segmentation/object_pixel_map.h"

#include <algorithm>
#include <cstring>
#include <string>

#include <opencv2/imgproc.hpp>

namespace hullpipe {

namespace {

// 8 bytes at a time: a map is mostly long runs (profiled: the per-pixel loop
// was capture_node's fourth-largest item).
bool HasZeroByte(uint64_t w) { return ((w - 0x0101010101010101ull) & ~w & 0x8080808080808080ull) != 0; }

// First index >= i in p[0, n) whose byte is (object ? zero : non-zero), else n.
size_t RunEnd(const uint8_t* p, size_t i, size_t n, bool object) {
  for (; i + 8 <= n; i += 8) {
    uint64_t w;
    std::memcpy(&w, p + i, 8);
    if (object ? HasZeroByte(w) : w != 0) break;
  }
  while (i < n && (p[i] != 0) == object) ++i;
  return i;
}

}  // namespace

std::vector<uint32_t> RunLengthEncode(const cv::Mat& map) {
  CV_Assert(map.type() == CV_8UC1);
  const cv::Mat m = map.isContinuous() ? map : map.clone();  // runs cross rows
  const uint8_t* p = m.ptr<uint8_t>();
  const size_t n = m.total();
  std::vector<uint32_t> runs;
  runs.reserve(64);
  bool object = false;  // runs start with background (the first may be 0 long)
  size_t i = 0;
  do {
    const size_t end = RunEnd(p, i, n, object);
    runs.push_back(uint32_t(end - i));
    i = end;
    object = !object;
  } while (i < n);
  return runs;
}

DecodedMap RunLengthDecodeMap(const uint32_t* runs, size_t count, int width, int height) {
  if (width <= 0 || height <= 0 || width > 16384 || height > 16384)
    throw MapDecodeError("object-pixel map size " + std::to_string(width) + "x" +
                         std::to_string(height) + " is out of range");
  const uint64_t total = uint64_t(width) * uint64_t(height);
  uint64_t sum = 0;
  for (size_t i = 0; i < count; ++i) sum += runs[i];
  if (sum != total)
    throw MapDecodeError("object-pixel map runs sum to " + std::to_string(sum) +
                         " pixels, expected " + std::to_string(total));
  DecodedMap d;
  d.map.create(height, width, CV_8UC1);
  uint8_t* const base = d.map.ptr<uint8_t>(0);  // freshly allocated: continuous
  uint8_t* out = base;
  uint8_t value = 0;
  const auto w = uint64_t(width);
  uint64_t x0 = w, y0 = uint64_t(height), x1 = 0, y1 = 0;  // inclusive bounds
  for (size_t i = 0; i < count; ++i) {
    std::fill(out, out + runs[i], value);
    if (value && runs[i] > 0) {
      // Object pixels [s, e] in row-major order: rows s / w .. e / w. A run over
      // more than one row reaches the last column of its first row and the
      // first column of its last: it spans every column.
      const auto s = uint64_t(out - base), e = s + runs[i] - 1;
      const uint64_t rs = s / w, re = e / w;
      y0 = std::min(y0, rs), y1 = std::max(y1, re);
      if (rs == re) {
        x0 = std::min(x0, s % w), x1 = std::max(x1, e % w);
      } else {
        x0 = 0, x1 = w - 1;
      }
      d.object_pixels += int64_t(runs[i]);
    }
    out += runs[i];
    value = value ? 0 : 255;
  }
  if (d.object_pixels > 0) d.bounds = cv::Rect(int(x0), int(y0), int(x1 - x0 + 1), int(y1 - y0 + 1));
  return d;
}

cv::Mat RunLengthDecode(const uint32_t* runs, size_t count, int width, int height) {
  return RunLengthDecodeMap(runs, count, width, height).map;
}

cv::Mat RunLengthDecode(const std::vector<uint32_t>& runs, int width, int height) {
  return RunLengthDecode(runs.data(), runs.size(), width, height);
}

cv::Rect ObjectBoundingRect(const cv::Mat& map) {
  CV_Assert(map.type() == CV_8UC1);
  return cv::boundingRect(map);
}

}  // namespace hullpipe
