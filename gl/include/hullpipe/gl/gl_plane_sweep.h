// The paper's plane sweep with stencil counting (§3.3) on the GPU (OpenGL 4.5
// core, headless EGL): the GPU twin of PlaneSweepCpu (plane_sweep.h), equal to
// it up to float rounding on silhouette borders; tests compare them.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/gl/egl_context.h"
#include "hullpipe/gl/gl_objects.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe::gl {

/// Most cameras a GL pass handles (texture units used at once).
inline constexpr int kMaxGlCameras = 16;

/// Plane sweep on the GPU. For each plane front to back: the stencil is cleared,
/// each camera's map is projected onto the plane (a full-tile quad whose fragments
/// are discarded where the plane point misses the camera's object pixels) with
/// stencil increment; then a quad with stencil == n writes the plane's depth under
/// a depth test so the first plane wins. Needs a current context (EglContext).
class GlPlaneSweep {
 public:
  GlPlaneSweep();
  /// Same contract as PlaneSweepCpu: CV_32FC1 tile of eye-z depths, kNoDepth where
  /// no plane is inside. Throws GlError, or std::invalid_argument for more than
  /// kMaxGlCameras cameras.
  cv::Mat Sweep(const VolumeQuery& query, const NovelView& view, const std::vector<double>& plane_depths,
                const cv::Rect& tile);

 private:
  void EnsureTarget(int width, int height);
  Program count_program_, resolve_program_;
  VertexArray vao_;
  Framebuffer fbo_;
  Texture depth_out_;
  Renderbuffer depth_stencil_;
  std::vector<Texture> maps_;
  int width_ = 0, height_ = 0;
};

}  // namespace hullpipe::gl
