// The per-triangle viewport query for collision detection (§4.1) on the GPU
// (OpenGL 4.5 compute shader, headless EGL): the GPU twin of QueryTriangleCpu
// (triangle_query.h), equal to it up to float rounding on the triangles' edges;
// tests compare them.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/gl/egl_context.h"
#include "hullpipe/gl/gl_objects.h"
#include "hullpipe/collision/triangle_query.h"
#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe::gl {

class LayerUploader;

/// What one batched GPU triangle query found (GlTriangleQuery::QueryBatch):
/// per triangle the pixels tested and inside, and which pixels were inside (a
/// bit per viewport pixel, kept only for triangles with one), so collision
/// points are made on the CPU only for the triangles asked about.
class TriangleBatchResult {
 public:
  /// Valid while the VolumeQuery it answered lives (Points may query a
  /// triangle again on the CPU).
  size_t size() const { return tested_.size(); }
  /// Pixel centres of triangle i's viewport inside it (QueryTriangleCpu's
  /// pixels_tested).
  int pixels_tested(size_t i) const { return tested_.at(i); }
  /// Of those, the ones inside the hull (its collision points' count).
  int inside(size_t i) const { return inside_.at(i); }
  /// Triangle i's collision points (world metres), in its viewport's row-major
  /// pixel order, as QueryTriangleCpu gives them.
  std::vector<Eigen::Vector3d> Points(size_t i) const;
  /// Every triangle's result as QueryTrianglesCpu gives them.
  std::vector<TriangleQueryResult> All() const;
  /// Where the batch's time went (wall ms): packing and uploading the maps,
  /// cameras and triangles; the pass (dispatch to its first read-back); reading
  /// counts and masks back; the CPU's pass over the counts.
  struct Timing {
    double prepare_ms = 0, pass_ms = 0, read_ms = 0, cpu_ms = 0;
  };
  const Timing& timing() const { return timing_; }

 private:
  friend class GlTriangleQuery;
  const VolumeQuery* query_ = nullptr;
  TriangleQueryOptions options_;
  std::vector<int> tested_, inside_;
  // Triangles with an inside pixel: their corners, mask offset (into masks_,
  // or kCentroid) and the GPU's viewport size, by index into these.
  std::vector<uint32_t> hit_of_;  // triangle -> index into the hit arrays (only where inside > 0)
  std::vector<Triangle> hit_triangles_;
  std::vector<uint32_t> hit_mask_, hit_size_;
  std::vector<uint32_t> masks_;
  Timing timing_;
};

/// Per-triangle viewport query on the GPU, one compute pass per batch: a
/// workgroup per triangle builds its viewport (MakeTriangleViewport, in float),
/// tests each pixel centre in the triangle (PixelInTriangle) and volume-queries
/// it against the n maps (one texture array, only their object rectangles
/// uploaded); inside pixels are kept as a bit mask per triangle that has any,
/// and one read-back brings counts and masks. A triangle a pixel thin is
/// sampled along its chords, one covering no pixel centre at its centroid, as
/// QueryTriangleCpu does.
class GlTriangleQuery {
 public:
  /// initial_mask_words: room for inside-pixel masks at first (grown and the
  /// pass run again when a batch needs more; small only to test that).
  explicit GlTriangleQuery(size_t initial_mask_words = size_t(1) << 16);
  ~GlTriangleQuery();
  GlTriangleQuery(const GlTriangleQuery&) = delete;
  GlTriangleQuery& operator=(const GlTriangleQuery&) = delete;
  /// The batched query: counts for every triangle, points on demand. Throws
  /// GlError on a GL error, std::invalid_argument as QueryTriangleCpu.
  TriangleBatchResult QueryBatch(const VolumeQuery& query, const std::vector<Triangle>& triangles,
                                 const TriangleQueryOptions& options);
  /// Results in triangle order, same contract as QueryTrianglesCpu (every
  /// collision point made).
  std::vector<TriangleQueryResult> Query(const VolumeQuery& query, const std::vector<Triangle>& triangles,
                                         const TriangleQueryOptions& options) {
    return QueryBatch(query, triangles, options).All();
  }

 private:
  Program program_;
  std::unique_ptr<LayerUploader> maps_;
  Buffer cams_, tris_, results_, masks_;
  size_t mask_capacity_;
  size_t tris_capacity_ = 0;      // triangles tris_ and results_ hold
  float* tris_mapped_ = nullptr;  // tris_, persistently mapped
};

}  // namespace hullpipe::gl
