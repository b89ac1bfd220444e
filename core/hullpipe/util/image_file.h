// Image files and encoded images read with bounds: the size comes from the
// header, checked before anything is decoded, and only the formats hullpipe
// reads are handed to OpenCV (PNG, JPEG, BMP, PNM, TIFF); a header claiming
// 20000x20000 px is refused in microseconds instead of decoded into gigabytes,
// and bytes of some other format never reach a decoder nobody here uses
// (docs/reliability.md, "Images").
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

namespace hullpipe {

/// What an image's header says.
struct ImageHeader {
  std::string format;  ///< "png", "jpeg", "bmp", "pnm" or "tiff"
  int width = 0;       ///< px, > 0
  int height = 0;      ///< px, > 0
};

/// The header of an encoded image in `data` (`size` bytes, the whole file or
/// at least its start): PNG (IHDR), JPEG (the first SOFn marker), BMP
/// (BITMAPINFOHEADER or later), binary or text PNM (P1..P6), TIFF (the first
/// IFD, either byte order). std::nullopt when the bytes are none of those, the
/// header is cut short, or a side is not in 1..2^31-1. Never reads past
/// `size`; O(number of JPEG markers before the SOF).
std::optional<ImageHeader> ParseImageHeader(const uint8_t* data, size_t size);

/// Limits of ReadImageFile and DecodeImage.
struct ImageLimits {
  int max_side = 16384;             ///< px, each side (Camera::kMaxSide)
  int64_t max_bytes = 256LL << 20;  ///< of the file
};

/// Decodes the encoded image in `data` with cv::imdecode(`flags`) after
/// ParseImageHeader: an empty Mat and `*why` (one phrase, no file name) when
/// the format is not one of the above, a side exceeds the limit, or the
/// decoder fails.
cv::Mat DecodeImage(const uint8_t* data, size_t size, int flags, std::string* why,
                    const ImageLimits& limits = {});

/// Reads the image file at `path` (a regular file: a FIFO or a device is
/// refused, never opened) and decodes it as DecodeImage. An empty Mat and
/// `*why` (naming `path`) on any failure.
cv::Mat ReadImageFile(const std::string& path, int flags, std::string* why, const ImageLimits& limits = {});

/// The size of the image file at `path` from its header alone (its first
/// 64 KiB are read, up to 4 MiB for a JPEG or PNM whose header lies deeper);
/// std::nullopt when it is not a regular file or ParseImageHeader fails.
std::optional<ImageHeader> ProbeImageFile(const std::string& path);

}  // namespace hullpipe
