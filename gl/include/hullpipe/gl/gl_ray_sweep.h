// The plane sweep built for a GPU (OpenGL 4.5 compute shaders, headless EGL): one
// invocation per pixel marches its ray over the sweep's planes front to back and
// stops at the first inside point, testing every camera at each plane point
// against the n object-pixel maps held in one texture array. This is the CPU
// sweep's algorithm (PlaneSweepCpu, paper §3.3 with the early exit), depth
// refinement included (bisection, near-miss scans and the silhouette pass, in a
// second compute pass), so it equals PlaneSweepCpu with the same planes and
// refinement up to float rounding; gl tests compare them. Several views are
// swept in one dispatch per pass (the visibility maps: one view per camera),
// their depths kept on the GPU for the texturing pass. The paper's
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
  /// 32 pixels a texel as bits; only the texels that hold each map's object
  /// rectangle, VolumeQuery::object_rect, through
  /// double-buffered pixel buffers: the copy does not wait for an earlier
  /// frameset's sweep). Every sweep until the next Upload uses these maps.
  /// Throws GlError on a GL error.
  void Upload(const VolumeQuery& query);
  /// Bytes the last Upload sent (4 per 32 pixels).
  size_t last_upload_bytes() const;

  /// Same contract as PlaneSweepCpu(query, view, depths, tile, nullptr, threads,
  /// refine_iterations): CV_32FC1 tile of eye-z depths (metres), kNoDepth where no
  /// plane is inside. `query` must be the one last given to Upload (its maps are
  /// not read again). Throws std::invalid_argument if it has a different number
  /// of cameras than the upload, GlError on a GL error.
  cv::Mat Sweep(const VolumeQuery& query, const NovelView& view, const std::vector<double>& plane_depths,
                const cv::Rect& tile, int refine_iterations = 0);
  /// Sweep's passes without its read-back: queues the march (and the
  /// silhouette pass) over `tile` and returns at once, true with the tile left
  /// on the GPU (tile_texture(), ReadTile), false where nothing is dispatched
  /// (no planes, an empty tile or hull box: every pixel is kNoDepth). Throws as
  /// Sweep.
  bool SweepOnGpu(const VolumeQuery& query, const NovelView& view, const std::vector<double>& plane_depths,
                  const cv::Rect& tile, int refine_iterations = 0);
  /// Reads the tile the last SweepOnGpu left (CV_32FC1 of its tile's size; all
  /// kNoDepth where it dispatched nothing). Waits for the GPU.
  cv::Mat ReadTile() const;
  /// The R32F texture array whose layer 0 holds the last Sweep's tile at (0, 0)
  /// on the GPU (what Sweep read back), or 0 when that Sweep dispatched nothing
  /// (no planes, an empty tile or hull box).
  GLuint tile_texture() const;

  /// Sweeps every view whole in one dispatch per pass, view k with
  /// plane_depths[k] (as Sweep over {0, 0, width, height}), and keeps the depths
  /// on the GPU: layer k of views_texture() (R32F, eye z in metres, +inf where
  /// no plane is inside), until the next SweepViews. Nothing is read back.
  /// Throws std::invalid_argument if the sizes of views and plane_depths differ
  /// or the query is not the uploaded one, GlError on a GL error.
  void SweepViews(const VolumeQuery& query, const std::vector<NovelView>& views,
                  const std::vector<std::vector<double>>& plane_depths, int refine_iterations = 0);
  /// The texture array SweepViews wrote (0 before the first).
  GLuint views_texture() const;
  /// Reads view k of the last SweepViews back (CV_32FC1 of its size). Throws
  /// std::out_of_range for a k it did not sweep.
  cv::Mat ReadView(size_t k) const;

  /// Whether the march skips the parts of each ray where at least two cameras
  /// veto every point by their maps' object rectangles alone (docs/gpu.md,
  /// "Narrowing the march"; default on). The depths are the same either way.
  void set_narrowing(bool on) { narrowing_ = on; }
  /// Whether each sweep counts the plane points its march asks the cameras
  /// about (an atomic add per pixel; default off, for tests and benchmarks).
  void set_counting(bool on) { counting_ = on; }
  /// The last sweep's count (0 when it did not count). Waits for the GPU.
  uint64_t points_asked() const;

 private:
  struct Target;  // the pass images of one kind of sweep
  void Run(const VolumeQuery& q, const std::vector<NovelView>& views, const std::vector<std::vector<double>>& depths,
           const std::vector<cv::Rect>& tiles, int refine, Target& target);
  Program march_, edges_;
  std::unique_ptr<LayerUploader> maps_;
  size_t uploaded_cameras_ = 0;
  Buffer cams_, planes_, views_, counter_;
  bool narrowing_ = true, counting_ = false, counted_ = false;
  std::unique_ptr<Target> tile_target_, view_target_;
  std::vector<cv::Size> view_sizes_;
  bool tile_valid_ = false;
  cv::Size tile_size_;  // the last SweepOnGpu's tile
};

}  // namespace hullpipe::gl
