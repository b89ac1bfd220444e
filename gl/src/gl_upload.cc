#include "gl_upload.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace hullpipe::gl {

namespace {

// Packs pixels 32 k .. 32 k + 31 of `row` (`cols` pixels; past them 0), for
// k in [k0, k0 + n), into words[0..n): bit i of a word set where its pixel i
// is not 0 (LayerUploader::Packing::kBits).
void PackRowBits(const uint8_t* row, int cols, int k0, int n, uint32_t* words) {
  for (int k = 0; k < n; ++k) {
    const int x = 32 * (k0 + k);
    uint32_t w = 0;
#if defined(__SSE2__)
    if (x + 32 <= cols) {
      const __m128i zero = _mm_setzero_si128();
      const __m128i lo = _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + x));
      const __m128i hi = _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + x + 16));
      const uint32_t zlo = uint32_t(_mm_movemask_epi8(_mm_cmpeq_epi8(lo, zero)));
      const uint32_t zhi = uint32_t(_mm_movemask_epi8(_mm_cmpeq_epi8(hi, zero)));
      words[k] = ~(zlo | zhi << 16);
      continue;
    }
#endif
    for (int i = 0; i < 32 && x + i < cols; ++i) w |= uint32_t(row[x + i] != 0) << i;
    words[k] = w;
  }
}

}  // namespace

LayerUploader::LayerUploader(GLenum internal_format, GLenum format, GLenum type, int mat_type, Packing packing)
    : internal_format_(internal_format),
      format_(format),
      type_(type),
      mat_type_(mat_type),
      bits_(packing == Packing::kBits),
      channels_(packing == Packing::kChannels ? CV_MAT_CN(mat_type) : 1) {
  if (bits_ && !(mat_type == CV_8UC1 && internal_format == GL_R32UI && format == GL_RED_INTEGER &&
                 type == GL_UNSIGNED_INT))
    throw std::invalid_argument("LayerUploader: bits need CV_8UC1 layers into GL_R32UI");
  if (packing == Packing::kChannels && !(CV_MAT_DEPTH(mat_type) == CV_8U && internal_format == GL_R8UI &&
                                         format == GL_RED_INTEGER && type == GL_UNSIGNED_BYTE))
    throw std::invalid_argument("LayerUploader: channels as texels need 8-bit layers into GL_R8UI");
}

void LayerUploader::Upload(const std::vector<cv::Mat>& layers, const std::vector<cv::Rect>* rects) {
  if (layers.empty()) throw std::invalid_argument("LayerUploader: no layers");
  if (rects && rects->size() != layers.size())
    throw std::invalid_argument("LayerUploader: " + std::to_string(rects->size()) + " rectangles for " +
                                std::to_string(layers.size()) + " layers");
  const size_t texel = bits_ ? 4 : size_t(CV_ELEM_SIZE(mat_type_) / channels_);
  // kBits: a layer of w pixels is (w + 31) / 32 texels wide; kChannels: 3 w.
  // A rectangle of pixels goes up as the texels that hold it.
  const auto texels = [&](const cv::Rect& r) {
    if (r.area() == 0) return r;
    if (channels_ > 1) return cv::Rect(r.x * channels_, r.y, r.width * channels_, r.height);
    if (!bits_) return r;
    const int x0 = r.x / 32, x1 = (r.x + r.width + 31) / 32;
    return cv::Rect(x0, r.y, x1 - x0, r.height);
  };
  int w = 0, h = 0;
  size_t bytes = 0;
  std::vector<cv::Rect> parts(layers.size());
  for (size_t i = 0; i < layers.size(); ++i) {
    const cv::Mat& m = layers[i];
    if (m.type() != mat_type_ || m.empty())
      throw std::invalid_argument("LayerUploader: layer of type " + std::to_string(m.type()) + ", expected " +
                                  std::to_string(mat_type_));
    w = std::max(w, bits_ ? (m.cols + 31) / 32 : m.cols * channels_);
    h = std::max(h, m.rows);
    parts[i] = cv::Rect(0, 0, m.cols, m.rows);
    if (rects) parts[i] &= (*rects)[i];
    parts[i] = texels(parts[i]);
    bytes += size_t(parts[i].area()) * texel;
  }
  if (w > width_ || h > height_ || int(layers.size()) > layers_) {
    GLint max_side = 0;
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_side);
    if (w > max_side || h > max_side)
      throw GlError("LayerUploader: layers of " + std::to_string(w) + "x" + std::to_string(h) +
                    " texels exceed this GL's largest texture (" + std::to_string(max_side) + ")");
    width_ = std::max(w, width_);
    height_ = std::max(h, height_);
    layers_ = std::max(int(layers.size()), layers_);
    texture_ = MakeTexture(GL_TEXTURE_2D_ARRAY);
    glTextureStorage3D(texture_.get(), 1, internal_format_, width_, height_, layers_);
    glTextureParameteri(texture_.get(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(texture_.get(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    CheckGl("texture array storage");
  }
  last_bytes_ = bytes;
  if (bytes == 0) return;
  Slot& s = slots_[size_t(next_)];
  next_ ^= 1;
  s.fence.Wait();  // the GPU has finished copying this buffer's last upload
  if (s.capacity < bytes) {
    s.pbo = MakeBuffer();
    s.capacity = std::max(bytes, s.capacity * 2);
    const GLbitfield flags = GL_MAP_WRITE_BIT | GL_MAP_PERSISTENT_BIT | GL_MAP_COHERENT_BIT;
    glNamedBufferStorage(s.pbo.get(), GLsizeiptr(s.capacity), nullptr, flags);
    s.mapped = glMapNamedBufferRange(s.pbo.get(), 0, GLsizeiptr(s.capacity), flags);
    if (!s.mapped) throw GlError("glMapNamedBufferRange of a pixel buffer failed");
  }
  glBindBuffer(GL_PIXEL_UNPACK_BUFFER, s.pbo.get());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  size_t offset = 0;
  for (size_t i = 0; i < layers.size(); ++i) {
    const cv::Rect& r = parts[i];
    if (r.area() == 0) continue;
    uint8_t* dst = static_cast<uint8_t*>(s.mapped) + offset;
    if (bits_) {
      for (int y = 0; y < r.height; ++y)
        PackRowBits(layers[i].ptr<uint8_t>(r.y + y), layers[i].cols, r.x, r.width,
                    reinterpret_cast<uint32_t*>(dst) + size_t(y) * size_t(r.width));
    } else {
      // (kChannels: the pixels under the texels r holds; their bytes are the texels.)
      const cv::Mat src = layers[i](cv::Rect(r.x / channels_, r.y, r.width / channels_, r.height));
      const size_t row = size_t(r.width) * texel;
      for (int y = 0; y < r.height; ++y) std::memcpy(dst + size_t(y) * row, src.ptr(y), row);
    }
    glTextureSubImage3D(texture_.get(), 0, r.x, r.y, GLint(i), r.width, r.height, 1, format_, type_,
                        reinterpret_cast<const void*>(offset));
    offset += size_t(r.area()) * texel;
  }
  glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
  s.fence.Insert();
  CheckGl("texture array upload");
}

}  // namespace hullpipe::gl
