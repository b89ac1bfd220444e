// Texturing the visual hull on the GPU (OpenGL 4.5 compute shader, headless EGL):
// the GPU twin of TextureHull (texture.h, paper §3.3), visibility test included,
// equal to it up to float rounding (gl tests compare them).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/gl/gl_objects.h"
#include "hullpipe/reconstruction/texture.h"
#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe::gl {

class LayerUploader;

/// Most cameras one texturing pass blends from (per-invocation arrays).
inline constexpr int kMaxTextureCameras = 32;

/// Hull texturing on the GPU. Needs a current context (EglContext).
class GlTexture {
 public:
  GlTexture();
  ~GlTexture();
  GlTexture(const GlTexture&) = delete;
  GlTexture& operator=(const GlTexture&) = delete;

  /// Uploads a frameset's colour images (CV_8UC3 BGR; one texture array layer
  /// each, a pixel's B, G, R bytes as three one-byte texels, through
  /// double-buffered pixel buffers). Every Texture call until the
  /// next upload reads these. With `rects` (one per image, image pixels), only
  /// that part of each image goes up (ObjectImageRects: the pixels a hull point
  /// can project to); a pass that samples an image outside its rectangle
  /// uploads that image whole and runs again, so the colours are the same as
  /// from whole images. Throws std::invalid_argument for more than
  /// kMaxTextureCameras images, a non-CV_8UC3 image or a rects list of another
  /// length, GlError on a GL error or an image wider than this GL's largest
  /// texture side / 3 (5,461 pixels where it is 16,384).
  void UploadImages(const std::vector<CameraImage>& images, const std::vector<cv::Rect>* rects = nullptr);
  /// Per image, the rectangle (image pixels, clipped to it) that holds every
  /// pixel the texture pass reads for a point the volume query `q` finds
  /// inside (ImageRectAroundObjectPixels of its camera's object rectangle).
  /// Empty for a camera with no object pixel. Images whose camera (by id, in
  /// order) is not the query's get the whole image.
  static std::vector<cv::Rect> ObjectImageRects(const VolumeQuery& q, const std::vector<CameraImage>& images);
  /// Bytes the last UploadImages copied (3 a pixel), and how many images the passes
  /// since had to upload whole again (a sample outside the image's rectangle).
  size_t uploaded_bytes() const { return uploaded_bytes_; }
  int64_t refetched_images() const { return refetched_; }
  /// Same contract as TextureHull(depth_tile, tile, view, images, options,
  /// visibility): CV_8UC3 of the tile's size. `images` must be the ones last
  /// uploaded (only their cameras and sizes are read here). Throws as TextureHull,
  /// std::invalid_argument if the images differ in number from the upload or
  /// options.max_cameras > kMaxTextureCameras, GlError on a GL error.
  cv::Mat Texture(const cv::Mat& depth_tile, const cv::Rect& tile, const NovelView& view,
                  const std::vector<CameraImage>& images, const TextureOptions& options = {},
                  const HullVisibility* visibility = nullptr);

  /// The same with visibility maps already on the GPU: layer k of
  /// `visibility_texture` (an R32F texture array, GlRaySweep::views_texture) is
  /// the hull's depth from visibility_views[k] (one per image), so nothing is
  /// uploaded for them; with depth_texture, layer 0 of that R32F texture array
  /// holds depth_tile already (GlRaySweep::tile_texture after the tile's
  /// Sweep), so neither is it. Throws std::invalid_argument if the number of
  /// views differs from the images'.
  cv::Mat Texture(const cv::Mat& depth_tile, const cv::Rect& tile, const NovelView& view,
                  const std::vector<CameraImage>& images, const TextureOptions& options,
                  const std::vector<NovelView>& visibility_views, GLuint visibility_texture,
                  GLuint depth_texture = 0);

  /// Texture's pass without its read-back: queues the pass over `tile` and
  /// returns at once; ReadBack reads its colour. The tile's depth is layer 0 of
  /// depth_texture (an R32F texture array, GlRaySweep::tile_texture after
  /// GlRaySweep::SweepOnGpu), or, with depth_texture 0, `depth` (CV_32FC1 of the
  /// tile's size, uploaded). visibility_views: as Texture's (one per image,
  /// layer k of visibility_texture), or nullptr for no visibility test. Throws
  /// as Texture, and std::invalid_argument with neither depth given.
  void Dispatch(const cv::Rect& tile, const NovelView& view, const std::vector<CameraImage>& images,
                const TextureOptions& options, const std::vector<NovelView>* visibility_views,
                GLuint visibility_texture, GLuint depth_texture, const cv::Mat* depth = nullptr);
  /// The last Dispatch's tile (CV_8UC3 BGR of its size; black where it
  /// dispatched nothing: an empty tile or no images). Waits for the GPU. When
  /// the pass sampled an image outside its uploaded rectangle, uploads that
  /// image whole and runs the pass again (refetched_images() counts them), so the
  /// depth and visibility textures the Dispatch named must be unchanged.
  cv::Mat ReadBack();

 private:
  cv::Mat Run(const cv::Mat& depth_tile, const cv::Rect& tile, const NovelView& view,
              const std::vector<CameraImage>& images, const TextureOptions& options,
              const std::vector<NovelView>* visibility_views, GLuint visibility_texture, GLuint depth_texture);
  Program program_;
  // Binds the pass's inputs as Dispatch set them (pending_) and queues it.
  void Launch();
  // Reads the pass's output into BGR.
  cv::Mat ReadOut() const;
  std::unique_ptr<LayerUploader> images_, visibility_;
  size_t uploaded_ = 0;
  std::vector<cv::Mat> kept_;        // the last upload's images (for a whole upload after a miss)
  std::vector<cv::Rect> rects_;      // the part of each that is on the GPU
  size_t uploaded_bytes_ = 0;
  int64_t refetched_ = 0;
  Buffer missing_;                   // the pass's bit mask of cameras sampled off their rectangle
  struct Pending {
    cv::Rect tile;
    NovelView view;
    TextureOptions options;
    bool vis = false;
    GLuint vis_texture = 0, depth_texture = 0;
  };
  Pending pending_;  // the last Dispatch's pass (its cameras in cams_)
  Buffer cams_, extra_;
  gl::Texture depth_, out_;
  int w_ = 0, h_ = 0;
  cv::Size out_size_;       // the last Dispatch's tile
  bool dispatched_ = false;  // whether it queued a pass
};

}  // namespace hullpipe::gl
