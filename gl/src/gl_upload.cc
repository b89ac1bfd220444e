#include "gl_upload.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

namespace hullpipe::gl {

LayerUploader::LayerUploader(GLenum internal_format, GLenum format, GLenum type, int mat_type)
    : internal_format_(internal_format), format_(format), type_(type), mat_type_(mat_type) {}

void LayerUploader::Upload(const std::vector<cv::Mat>& layers) {
  if (layers.empty()) throw std::invalid_argument("LayerUploader: no layers");
  int w = 0, h = 0;
  size_t bytes = 0;
  for (const cv::Mat& m : layers) {
    if (m.type() != mat_type_ || m.empty())
      throw std::invalid_argument("LayerUploader: layer of type " + std::to_string(m.type()) + ", expected " +
                                  std::to_string(mat_type_));
    w = std::max(w, m.cols);
    h = std::max(h, m.rows);
    bytes += m.total() * m.elemSize();
  }
  if (w > width_ || h > height_ || int(layers.size()) > layers_) {
    width_ = std::max(w, width_);
    height_ = std::max(h, height_);
    layers_ = std::max(int(layers.size()), layers_);
    texture_ = MakeTexture(GL_TEXTURE_2D_ARRAY);
    glTextureStorage3D(texture_.get(), 1, internal_format_, width_, height_, layers_);
    glTextureParameteri(texture_.get(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(texture_.get(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    CheckGl("texture array storage");
  }
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
    const cv::Mat& m = layers[i];
    const size_t row = size_t(m.cols) * m.elemSize();
    for (int r = 0; r < m.rows; ++r)
      std::memcpy(static_cast<uint8_t*>(s.mapped) + offset + size_t(r) * row, m.ptr(r), row);
    glTextureSubImage3D(texture_.get(), 0, 0, 0, GLint(i), m.cols, m.rows, 1, format_, type_,
                        reinterpret_cast<const void*>(offset));
    offset += row * size_t(m.rows);
  }
  glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
  s.fence.Insert();
  CheckGl("texture array upload");
}

}  // namespace hullpipe::gl
