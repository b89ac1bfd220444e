#include "hullpipe/util/image_file.h"

#include <sys/stat.h>

#include <climits>
#include <cstring>
#include <fstream>
#include <vector>

#include <opencv2/imgcodecs.hpp>

namespace hullpipe {
namespace {

uint32_t Be16(const uint8_t* p) { return uint32_t(p[0]) << 8 | p[1]; }
uint32_t Be32(const uint8_t* p) { return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3]; }
uint32_t Le16(const uint8_t* p) { return uint32_t(p[1]) << 8 | p[0]; }
uint32_t Le32(const uint8_t* p) { return uint32_t(p[3]) << 24 | uint32_t(p[2]) << 16 | uint32_t(p[1]) << 8 | p[0]; }

std::optional<ImageHeader> Make(const char* format, int64_t w, int64_t h) {
  if (w <= 0 || h <= 0 || w > INT_MAX || h > INT_MAX) return std::nullopt;
  return ImageHeader{format, int(w), int(h)};
}

// PNG: signature, then the IHDR chunk first (PNG specification, 5.2, 11.2.2).
std::optional<ImageHeader> Png(const uint8_t* d, size_t n) {
  static const uint8_t kSig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (n < 24 || std::memcmp(d, kSig, 8) != 0 || std::memcmp(d + 12, "IHDR", 4) != 0) return std::nullopt;
  return Make("png", Be32(d + 16), Be32(d + 20));
}

// JPEG: markers up to the first start of frame (ITU T.81, B.1.1.3, B.2.2).
std::optional<ImageHeader> Jpeg(const uint8_t* d, size_t n) {
  if (n < 4 || d[0] != 0xff || d[1] != 0xd8) return std::nullopt;
  size_t i = 2;
  while (i + 1 < n) {
    if (d[i] != 0xff) return std::nullopt;  // a segment must start at a marker
    while (i < n && d[i] == 0xff) ++i;       // fill bytes
    if (i >= n) return std::nullopt;
    const uint8_t m = d[i++];
    if (m == 0x01 || (m >= 0xd0 && m <= 0xd8)) continue;  // no length
    if (m == 0xd9 || m == 0xda) return std::nullopt;      // end, or scan before a frame
    if (i + 2 > n) return std::nullopt;
    const size_t len = Be16(d + i);
    if (len < 2) return std::nullopt;
    const bool sof = m >= 0xc0 && m <= 0xcf && m != 0xc4 && m != 0xc8 && m != 0xcc;
    if (sof) {
      if (len < 7 || i + 7 > n) return std::nullopt;
      return Make("jpeg", Be16(d + i + 5), Be16(d + i + 3));
    }
    i += len;
  }
  return std::nullopt;
}

// BMP: file header, then BITMAPCOREHEADER (12 bytes) or an info header.
std::optional<ImageHeader> Bmp(const uint8_t* d, size_t n) {
  if (n < 26 || d[0] != 'B' || d[1] != 'M') return std::nullopt;
  const uint32_t header = Le32(d + 14);
  if (header == 12) return Make("bmp", Le16(d + 18), Le16(d + 20));
  if (header < 40) return std::nullopt;
  const int64_t w = int32_t(Le32(d + 18));
  const int64_t h = int32_t(Le32(d + 22));
  return Make("bmp", w, h < 0 ? -h : h);  // negative height: rows top-down
}

// PNM (Netpbm): "P1".."P6", then width and height in ASCII decimal, with
// whitespace and '#' comments between the fields.
std::optional<ImageHeader> Pnm(const uint8_t* d, size_t n) {
  if (n < 3 || d[0] != 'P' || d[1] < '1' || d[1] > '6') return std::nullopt;
  size_t i = 2;
  int64_t v[2] = {0, 0};
  for (int64_t& x : v) {
    for (;;) {
      while (i < n && std::strchr(" \t\r\n\v\f", d[i]) && d[i]) ++i;
      if (i < n && d[i] == '#') {
        while (i < n && d[i] != '\n') ++i;
        continue;
      }
      break;
    }
    const size_t start = i;
    while (i < n && d[i] >= '0' && d[i] <= '9' && i - start < 11) x = x * 10 + (d[i++] - '0');
    if (i == start || (i < n && d[i] >= '0' && d[i] <= '9')) return std::nullopt;  // none, or too many digits
  }
  return Make("pnm", v[0], v[1]);
}

// TIFF: the first image file directory's ImageWidth (256) and ImageLength
// (257), SHORT or LONG (TIFF 6.0, section 2 and 8).
std::optional<ImageHeader> Tiff(const uint8_t* d, size_t n) {
  if (n < 8) return std::nullopt;
  const bool le = d[0] == 'I' && d[1] == 'I' && d[2] == 42 && d[3] == 0;
  const bool be = d[0] == 'M' && d[1] == 'M' && d[2] == 0 && d[3] == 42;
  if (!le && !be) return std::nullopt;
  auto u16 = [&](size_t at) { return le ? Le16(d + at) : Be16(d + at); };
  auto u32 = [&](size_t at) { return le ? Le32(d + at) : Be32(d + at); };
  const size_t ifd = u32(4);
  if (ifd < 8 || ifd > n || n - ifd < 2) return std::nullopt;
  const size_t count = u16(ifd);
  if ((n - ifd - 2) / 12 < count) return std::nullopt;
  int64_t w = 0, h = 0;
  for (size_t e = 0; e < count; ++e) {
    const size_t at = ifd + 2 + 12 * e;
    const uint32_t tag = u16(at), type = u16(at + 2), values = u32(at + 4);
    if ((tag != 256 && tag != 257) || values != 1) continue;
    int64_t x = 0;
    if (type == 3) x = u16(at + 8);
    else if (type == 4) x = u32(at + 8);
    else return std::nullopt;
    (tag == 256 ? w : h) = x;
  }
  return Make("tiff", w, h);
}

}  // namespace

std::optional<ImageHeader> ParseImageHeader(const uint8_t* data, size_t size) {
  if (!data) return std::nullopt;
  for (auto* parse : {Png, Jpeg, Bmp, Pnm, Tiff})
    if (auto h = parse(data, size)) return h;
  return std::nullopt;
}

cv::Mat DecodeImage(const uint8_t* data, size_t size, int flags, std::string* why, const ImageLimits& limits) {
  const std::optional<ImageHeader> h = ParseImageHeader(data, size);
  if (!h) {
    *why = "not a PNG, JPEG, BMP, PNM or TIFF image (or its header is cut short)";
    return {};
  }
  if (h->width > limits.max_side || h->height > limits.max_side) {
    *why = "its " + h->format + " header says " + std::to_string(h->width) + "x" + std::to_string(h->height) +
           " px, beyond " + std::to_string(limits.max_side) + " px a side";
    return {};
  }
  if (size > size_t(INT_MAX)) {
    *why = "larger than 2 GiB";
    return {};
  }
  cv::Mat img;
  try {
    img = cv::imdecode(cv::Mat(1, int(size), CV_8UC1, const_cast<uint8_t*>(data)), flags);
  } catch (const cv::Exception&) {
    img.release();
  }
  if (img.empty()) {
    *why = "its " + h->format + " data does not decode";
    return {};
  }
  if (img.cols != h->width || img.rows != h->height) {
    *why = "decodes to " + std::to_string(img.cols) + "x" + std::to_string(img.rows) + " px, its header says " +
           std::to_string(h->width) + "x" + std::to_string(h->height);
    return {};
  }
  return img;
}

namespace {

// Up to `max` bytes from the start of the regular file at `path`; false and
// `*why` when it is not one or cannot be read.
bool ReadPrefix(const std::string& path, int64_t max, std::vector<uint8_t>* bytes, int64_t* file_size,
                std::string* why) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    *why = path + ": cannot open";
    return false;
  }
  if (!S_ISREG(st.st_mode)) {
    *why = path + ": not a regular file";
    return false;
  }
  *file_size = int64_t(st.st_size);
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *why = path + ": cannot open";
    return false;
  }
  bytes->resize(size_t(std::min<int64_t>(max, st.st_size)));
  in.read(reinterpret_cast<char*>(bytes->data()), std::streamsize(bytes->size()));
  bytes->resize(size_t(in.gcount()));
  return true;
}

}  // namespace

cv::Mat ReadImageFile(const std::string& path, int flags, std::string* why, const ImageLimits& limits) {
  std::vector<uint8_t> bytes;
  int64_t size = 0;
  if (!ReadPrefix(path, limits.max_bytes + 1, &bytes, &size, why)) return {};
  if (int64_t(bytes.size()) > limits.max_bytes) {
    *why = path + ": larger than " + std::to_string(limits.max_bytes >> 20) + " MiB, not an image hullpipe reads";
    return {};
  }
  cv::Mat img = DecodeImage(bytes.data(), bytes.size(), flags, why, limits);
  if (img.empty()) *why = path + ": " + *why;
  return img;
}

std::optional<ImageHeader> ProbeImageFile(const std::string& path) {
  std::vector<uint8_t> bytes;
  int64_t size = 0;
  std::string why;
  // 64 KiB first: PNG, BMP and TIFF's first bytes say whether they are that
  // format, and most headers are there. Only a JPEG (segments before its start
  // of frame) or a PNM (comments before its size) may need more, up to 4 MiB:
  // a video file probed as a camera spec, or every frame of an image sequence,
  // is not read 4 MiB at a time.
  if (!ReadPrefix(path, 64 << 10, &bytes, &size, &why)) return std::nullopt;
  if (auto h = ParseImageHeader(bytes.data(), bytes.size())) return h;
  const bool deeper = bytes.size() >= 2 && ((bytes[0] == 0xff && bytes[1] == 0xd8) || bytes[0] == 'P');
  if (deeper && size > int64_t(bytes.size())) {
    if (!ReadPrefix(path, 4 << 20, &bytes, &size, &why)) return std::nullopt;
    if (auto h = ParseImageHeader(bytes.data(), bytes.size())) return h;
  }
  // A TIFF's directory may follow its pixels: read the file whole if bounded.
  const bool tiff = bytes.size() >= 4 && (std::memcmp(bytes.data(), "II*\0", 4) == 0 ||
                                          std::memcmp(bytes.data(), "MM\0*", 4) == 0);
  if (tiff && size > int64_t(bytes.size()) && size <= (256LL << 20) &&
      ReadPrefix(path, size, &bytes, &size, &why))
    return ParseImageHeader(bytes.data(), bytes.size());
  return std::nullopt;
}

}  // namespace hullpipe
