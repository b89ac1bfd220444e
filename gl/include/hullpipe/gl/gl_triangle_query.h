// The per-triangle viewport query for collision detection (§4.1) on the GPU
// (OpenGL 4.5 core, headless EGL): the GPU twin of QueryTriangleCpu
// (triangle_query.h), equal to it up to float rounding on silhouette borders;
// tests compare them.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/gl/egl_context.h"
#include "hullpipe/gl/gl_objects.h"
#include "hullpipe/collision/triangle_query.h"
#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe::gl {

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
