// Streaming uploads of per-frame images into one texture array (private to
// hullpipe_gl): the layers are copied into one of two persistently mapped pixel
// buffers and the GPU copies them into the array from there, so the CPU's copy of
// frame f+1 waits only for the GPU to have consumed frame f-1's buffer, never for
// frame f's sweep (pixel buffer objects, double-buffered).
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/gl/gl_objects.h"

namespace hullpipe::gl {

class LayerUploader {
 public:
  /// internal_format/format/type as glTexStorage3D/glTexSubImage3D take them;
  /// mat_type: the cv::Mat type every layer must have (e.g. CV_8UC1).
  LayerUploader(GLenum internal_format, GLenum format, GLenum type, int mat_type);
  /// Uploads layers[i] into layer i (row 0 of a Mat = texel row 0). Layers may
  /// differ in size; the array is as large as the largest (texels beyond a
  /// layer's own size are undefined: shaders bound-check). Throws
  /// std::invalid_argument for a wrong Mat type or no layers, GlError on a GL error.
  void Upload(const std::vector<cv::Mat>& layers);
  GLuint texture() const { return texture_.get(); }

 private:
  struct Slot {
    Buffer pbo;
    void* mapped = nullptr;
    size_t capacity = 0;
    Fence fence;
  };
  GLenum internal_format_, format_, type_;
  int mat_type_;
  Texture texture_;
  int width_ = 0, height_ = 0, layers_ = 0;
  std::array<Slot, 2> slots_;
  int next_ = 0;
};

}  // namespace hullpipe::gl
