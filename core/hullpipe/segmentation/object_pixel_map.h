// Object-pixel maps (paper §3.1): per camera, a binary image where object pixels
// (the real objects, segmented against the background) are non-zero.
// In memory: cv::Mat of CV_8UC1, 0 = background, 255 = object (conventions.h).
// On the wire: run-length encoded (RunLengthEncode), because a silhouette of a
// 644x486 map is ~2,000 runs (~8 KB) instead of 313 KB of pixels.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <vector>

#include <opencv2/core.hpp>

namespace hullpipe {

/// A map whose size or encoding does not add up; what() says how.
class MapDecodeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Run-length encoding of a binary map, row-major over the whole image: runs
/// alternate background, object, background, ... starting with background (the
/// first run may be 0). Run lengths are uint32. The runs sum to width*height.
std::vector<uint32_t> RunLengthEncode(const cv::Mat& map);

/// A map decoded from its runs, with what the runs give for free.
struct DecodedMap {
  cv::Mat map;               ///< CV_8UC1, object = 255.
  cv::Rect bounds;           ///< The object pixels' bounding rectangle (empty if none): cv::boundingRect(map).
  int64_t object_pixels = 0; ///< Object pixels in all.
};

/// Decodes runs into a map of the given size with its bounding rectangle and
/// object-pixel count, found from the runs (no second pass over the pixels).
/// Throws MapDecodeError as RunLengthDecode.
DecodedMap RunLengthDecodeMap(const uint32_t* runs, size_t count, int width, int height);

/// Decodes runs into a CV_8UC1 map of the given size (object = 255).
/// Throws MapDecodeError if the runs do not sum to width*height, or the size is
/// non-positive or larger than 16384 on a side.
cv::Mat RunLengthDecode(const std::vector<uint32_t>& runs, int width, int height);

/// Same, from a raw pointer + count (as received in a DDS sequence).
cv::Mat RunLengthDecode(const uint32_t* runs, size_t count, int width, int height);

/// Axis-aligned bounding rectangle of the object pixels (empty Rect if none).
cv::Rect ObjectBoundingRect(const cv::Mat& map);

}  // namespace hullpipe
