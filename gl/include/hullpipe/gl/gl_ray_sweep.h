// The plane sweep built for a GPU (OpenGL 4.5 compute shaders, headless EGL): one
// invocation per pixel marches its ray over the sweep's planes front to back and
// stops at the first inside point, testing every camera at each plane point
// against the n object-pixel maps held in one texture array. This is the CPU
// sweep's algorithm (PlaneSweepCpu, paper §3.3 with the early exit), depth
// refinement included (bisection, near-miss scans and the silhouette pass, in a
// second compute pass), so it equals PlaneSweepCpu with the same planes and
// refinement up to float rounding; gl tests compare them. The paper's
// stencil-counting sweep (GlPlaneSweep) stays as the reference GL method.
#pragma once

#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/gl/gl_objects.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe::gl {

class LayerUploader;

/// Plane sweep by ray marching on the GPU. Needs a current context (EglContext).
class GlRaySweep {
 public:
  GlRaySweep();
  ~GlRaySweep();
  GlRaySweep(const GlRaySweep&) = delete;
  GlRaySweep& operator=(const GlRaySweep&) = delete;

  /// Uploads a frameset's object-pixel maps (one texture array layer per camera,
  /// through double-buffered pixel buffers: the copy does not wait for an earlier
  /// frameset's sweep). Every Sweep until the next Upload uses these maps. Throws
  /// GlError on a GL error.
  void Upload(const VolumeQuery& query);

  /// Same contract as PlaneSweepCpu(query, view, depths, tile, nullptr, threads,
  /// refine_iterations): CV_32FC1 tile of eye-z depths (metres), kNoDepth where no
  /// plane is inside. `query` must be the one last given to Upload (its maps are
  /// not read again). Throws std::invalid_argument if it has a different number
  /// of cameras than the upload, GlError on a GL error.
  cv::Mat Sweep(const VolumeQuery& query, const NovelView& view, const std::vector<double>& plane_depths,
                const cv::Rect& tile, int refine_iterations = 0);

 private:
  void EnsureImages(int width, int height);
  Program march_, edges_;
  std::unique_ptr<LayerUploader> maps_;
  size_t uploaded_cameras_ = 0;
  Buffer cams_, planes_;
  Texture swept_, refined_;
  int image_w_ = 0, image_h_ = 0;
};

}  // namespace hullpipe::gl
