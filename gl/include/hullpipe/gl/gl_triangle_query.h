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

/// Per-triangle viewport query on the GPU: every triangle's viewport is a cell of
/// one atlas framebuffer (the paper packed 10x10 viewports in a 400x400 window),
/// all drawn with one draw call (the vertex shader places each triangle, seen
/// orthographically along its normal, in its cell); every fragment volume-queries
/// its interpolated world point against all n maps and adds itself to its
/// triangle's count, and an inside one appends its point to a buffer; one
/// readback of counts and points. An atlas larger than max_atlas x max_atlas
/// pixels is drawn in several passes into the same buffers.
class GlTriangleQuery {
 public:
  /// max_atlas: the atlas's side in pixels (GL guarantees 16384 for a
  /// framebuffer without attachments); smaller only to test the passes. Throws
  /// std::invalid_argument below 64 (the largest viewport).
  explicit GlTriangleQuery(int max_atlas = 16384);
  /// Results in triangle order, same contract as QueryTriangleCpu (a triangle
  /// with no covered pixel centre is queried at its centroid on the CPU; one a
  /// pixel thin is sampled on the CPU as there). A triangle's collision points
  /// are in its viewport's row-major pixel order, as on the CPU. Throws GlError
  /// on a GL error, std::invalid_argument as QueryTriangleCpu.
  std::vector<TriangleQueryResult> Query(const VolumeQuery& query, const std::vector<Triangle>& triangles,
                                         const TriangleQueryOptions& options);

 private:
  Program program_;
  VertexArray vao_;
  Buffer vbo_, counts_, points_;
  Framebuffer fbo_;
  std::vector<Texture> maps_;
  size_t point_capacity_ = 0;
  int max_atlas_;
};

}  // namespace hullpipe::gl
