// Streaming uploads of per-frame images into one texture array (private to
// hullpipe_gl): the layers are copied into one of two persistently mapped pixel
// buffers and the GPU copies them into the array from there, so the CPU's copy of
// frame f+1 waits only for the GPU to have consumed frame f-1's buffer, never for
// frame f's sweep (pixel buffer objects, double-buffered). Only a rectangle of
// each layer may be sent (the object pixels of a map: the rest is background and
// never read). Object-pixel maps go up as bits, 32 pixels a texel (kBits): an
// eighth of their bytes, and of the texture cache the volume queries read
// through; colour images as three one-byte texels a pixel (kChannels).
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/gl/gl_objects.h"

namespace hullpipe::gl {

/// GLSL for a shader that reads a texture array LayerUploader::Packing::kBits
/// filled: ObjectPixelBit(maps, x, y, layer) is 1 where pixel (x, y) of the
/// layer's map is not 0, else 0 (x, y within the layer's map).
inline const char* kObjectPixelBitGlsl = R"(
int ObjectPixelBit(usampler2DArray maps, int x, int y, int layer) {
  return int((texelFetch(maps, ivec3(x >> 5, y, layer), 0).r >> uint(x & 31)) & 1u);
}
)";

class LayerUploader {
 public:
  /// kTexels: a layer's pixels are its texels. kBits (CV_8UC1 layers into a
  /// GL_R32UI array): texel (tx, y) holds pixels 32 tx .. 32 tx + 31 of row y,
  /// bit i set where pixel 32 tx + i is not 0 (pixels past the layer's width
  /// are 0); a shader reads pixel (x, y) as
  /// (texelFetch(t, ivec3(x >> 5, y, layer), 0).r >> (x & 31)) & 1.
  /// kChannels (CV_8UC3 layers into a GL_R8UI array): a pixel's three bytes
  /// are three texels side by side, texel (3 x + i, y) channel i of pixel
  /// (x, y), copied as they are (an RGB8 texture is stored as four bytes a
  /// texel, so the driver or the CPU would expand every pixel; this sends
  /// three). Layers at most GL_MAX_TEXTURE_SIZE / 3 pixels wide.
  enum class Packing { kTexels, kBits, kChannels };
  /// internal_format/format/type as glTexStorage3D/glTexSubImage3D take them;
  /// mat_type: the cv::Mat type every layer must have (e.g. CV_8UC1). Throws
  /// std::invalid_argument for a packing the formats do not fit.
  LayerUploader(GLenum internal_format, GLenum format, GLenum type, int mat_type,
                Packing packing = Packing::kTexels);
  /// Uploads layers[i] into layer i (row 0 of a Mat = texel row 0). Layers may
  /// differ in size; the array is as large as the largest (texels beyond a
  /// layer's own size are undefined: shaders bound-check). With `rects`, only
  /// rects[i] (clipped to the layer) of layer i goes up; the rest of the layer
  /// keeps older contents, which shaders must not read (kBits: the texels
  /// that hold any of rects[i]'s pixels go up, so the pixels beside it in
  /// those texels are the layer's own). Throws
  /// std::invalid_argument for a wrong Mat type, no layers or a rects list of
  /// another length, GlError on a GL error or layers wider or taller (in
  /// texels) than GL_MAX_TEXTURE_SIZE.
  void Upload(const std::vector<cv::Mat>& layers, const std::vector<cv::Rect>* rects = nullptr);
  GLuint texture() const { return texture_.get(); }
  /// Bytes copied by the last Upload.
  size_t last_bytes() const { return last_bytes_; }

 private:
  struct Slot {
    Buffer pbo;
    void* mapped = nullptr;
    size_t capacity = 0;
    Fence fence;
  };
  GLenum internal_format_, format_, type_;
  int mat_type_;
  bool bits_ = false;    // Packing::kBits
  int channels_ = 1;     // texels a pixel takes (Packing::kChannels: the Mat's channels)
  Texture texture_;
  int width_ = 0, height_ = 0, layers_ = 0;
  std::array<Slot, 2> slots_;
  int next_ = 0;
  size_t last_bytes_ = 0;
};

}  // namespace hullpipe::gl
