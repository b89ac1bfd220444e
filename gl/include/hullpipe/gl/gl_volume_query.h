// GPU (OpenGL 4.5 core, headless EGL) twins of the core's volume-query algorithms:
// the paper's plane sweep with stencil counting (§3.3) and the per-triangle
// viewport query for collision detection (§4.1). Each matches its CPU reference
// (plane_sweep.h, triangle_query.h) up to float rounding on silhouette borders;
// tests compare them.
#pragma once

#include <memory>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "hullpipe/gl/egl_context.h"
#include "hullpipe/gl/gl_objects.h"
#include "hullpipe/plane_sweep.h"
#include "hullpipe/triangle_query.h"
#include "hullpipe/volume_query.h"

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

/// Per-triangle viewport query on the GPU: triangles are packed in cells of an
/// atlas (the paper packed 10x10 viewports in a 400x400 window), each drawn with
/// an orthographic view along its normal; every fragment volume-queries its
/// interpolated world point against all n maps in the shader.
class GlTriangleQuery {
 public:
  GlTriangleQuery();
  /// Results in triangle order, same contract as QueryTriangleCpu (a triangle
  /// with no covered pixel centre is queried at its centroid on the CPU).
  std::vector<TriangleQueryResult> Query(const VolumeQuery& query, const std::vector<Triangle>& triangles,
                                         const TriangleQueryOptions& options);

 private:
  Program program_;
  VertexArray vao_;
  Buffer vbo_;
  Framebuffer fbo_;
  Texture colour_;
  std::vector<Texture> maps_;
  int atlas_ = 0;
};

}  // namespace hullpipe::gl
