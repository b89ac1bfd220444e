// What renders a frameset's hull for recon_node and the benchmarks (paper §3.3):
// the sweep, the visibility maps and the texture, behind one interface. The CPU
// implementation here is the reference (plane_sweep.h, texture.h); the GPU one
// lives in gl/ (gl/backend.h: MakeSweepBackend picks between them, docs/gpu.md
// says what `auto` picks and why). The core knows only the interface, so the
// node controllers and the tools that need no GPU link no GL.
#pragma once

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/texture.h"
#include "hullpipe/util/interrupt.h"

namespace hullpipe {

/// A tile swept and textured (SweepBackend::SweepTextured).
struct TexturedTile {
  cv::Mat depth;   ///< CV_32FC1 eye-z depths, metres, kNoDepth off the hull (as Sweep).
  cv::Mat colour;  ///< CV_8UC3 BGR (as Texture).
  /// Wall milliseconds of the texture (the latency budget's recon "texture",
  /// docs/latency.md): the CPU's texturing; on the GL backend only what follows
  /// the one read-back, whose wait for both passes counts as the sweep's.
  double texture_ms = 0;
  /// Images the GL texture pass had to upload whole and run again for this
  /// tile: it sampled them outside the part uploaded for the frameset (the
  /// pixels around their object pixels; gl_texture.h). 0 on the CPU.
  int refetched_images = 0;
};

/// What renders a frameset's hull: sweep, visibility maps and texture.
/// Per frameset: BeginFrameset, then ComputeVisibility (if the texture is to
/// use it), then any number of Sweep / Texture calls on that frameset's query
/// and images (which must outlive them).
class SweepBackend {
 public:
  virtual ~SweepBackend() = default;
  /// Starts a frameset (the GL backend uploads its maps and images here, once).
  virtual void BeginFrameset(const VolumeQuery& query, const std::vector<CameraImage>& images) = 0;
  /// Same contract as PlaneSweepCpu with the backend's refinement; `query` is the
  /// one given to BeginFrameset. stats (optional): the work and wall times
  /// (SweepStats::sweep_ms, refine_ms; a refinement done inside the sweep's own
  /// pass, as the GL ray march's, counts as sweep).
  virtual cv::Mat Sweep(const VolumeQuery& query, const NovelView& view, const std::vector<double>& depths,
                        const cv::Rect& tile, SweepStats* stats = nullptr) = 0;
  /// The visibility maps of the frameset begun last (same contract as
  /// ComputeHullVisibility with the backend's refinement), kept for its Texture
  /// calls: the GL backend sweeps all cameras' views in one dispatch and keeps
  /// the maps on the GPU, reading nothing back.
  virtual void ComputeVisibility(const VolumeQuery& query, const std::vector<Camera>& cameras, int width,
                                 const PlaneSweepOptions& sweep) = 0;
  /// The maps ComputeVisibility kept, on the CPU (read back from the GPU: for
  /// tests and benchmarks); empty views before it in this frameset.
  virtual HullVisibility KeptVisibility() = 0;
  /// Same contract as TextureHull; `images` are the ones given to BeginFrameset;
  /// with_visibility: the visibility test with the maps ComputeVisibility kept
  /// (std::logic_error if it was not called for this frameset). A depth_tile
  /// that Sweep returned must be passed unchanged: the GL backend textures the
  /// last one from its own copy on the GPU.
  virtual cv::Mat Texture(const cv::Mat& depth_tile, const cv::Rect& tile, const NovelView& view,
                          const std::vector<CameraImage>& images, bool with_visibility) = 0;
  /// Sweep, then Texture of the depth it returns, in one call: what recon_node
  /// does for each tile (paper §3.3: the hull's depth, then its colour), with
  /// the same results as the two calls. The GL march queues both passes and
  /// reads the depth and the colour back together, so the frame waits for the
  /// GPU once, not once per pass. stats as Sweep's (on GL the sweep's wall time
  /// includes the texture pass, which runs before the one read-back).
  virtual TexturedTile SweepTextured(const VolumeQuery& query, const NovelView& view,
                                     const std::vector<double>& depths, const cv::Rect& tile,
                                     const std::vector<CameraImage>& images, bool with_visibility,
                                     SweepStats* stats = nullptr);
  /// "cpu", "gl march (renderer)" or "gl stencil (renderer)".
  virtual std::string Name() const = 0;
  /// The GL implementation in use in one line (vendor, renderer, version), or
  /// empty for the CPU backend (NodeStats' backend field).
  virtual std::string GlSummary() const { return {}; }
  /// Why this backend was chosen (for the log): e.g. "auto: GL renderer is
  /// software (llvmpipe ...); the CPU sweep is faster there".
  const std::string& reason() const { return reason_; }
  void set_reason(std::string r) { reason_ = std::move(r); }
  /// The flag Sweep, Visibility and Texture poll (util/interrupt.h): once set they
  /// throw Interrupted. The CPU backend polls per pixel or row, and the GL
  /// stencil method in its CPU refinement; GL draws and dispatches, once queued,
  /// run to their end. nullptr (the default) never stops.
  void set_stop(StopFlag stop) { stop_ = stop; }
  StopFlag stop() const { return stop_; }
  /// CPU threads for the work done on the CPU (the CPU backend's sweep,
  /// visibility maps; the stencil method's refinement), from the next call on;
  /// clamped to [1, 256].
  void set_threads(int threads) { threads_ = std::clamp(threads, 1, 256); }
  int threads() const { return threads_; }
  /// Returns once the work issued so far is done (the GL backend queues its
  /// dispatches and returns: glFinish). For timing the stages one by one.
  virtual void Finish() {}

 private:
  std::string reason_;
  StopFlag stop_ = nullptr;
  int threads_ = 1;
};

/// How to make a backend (gl/backend.h: MakeSweepBackend).
struct BackendOptions {
  /// "cpu", "gl" or "auto". auto takes GL on a hardware renderer and the CPU on a
  /// software one (Mesa's llvmpipe, where the CPU path is faster), and the CPU
  /// where no GL context can be made.
  std::string name = "auto";
  int threads = 1;  ///< CPU threads at the start (SweepBackend::set_threads).
  /// Depth refinement bisections after the sweep (PlaneSweepCpu; 0 = the paper's
  /// plane-quantised depth).
  int refine = 0;
  /// GL sweep: "march" (compute shader ray march, refinement on the GPU) or
  /// "stencil" (the paper's stencil counting; refinement on the CPU).
  std::string gl_method = "march";
  int gl_device = -1;  ///< EGL device (EglOptions::device); -1 picks.
  /// GL: render one small synthetic frame at creation, so that the first
  /// frameset does not pay for the driver's first dispatches (off only for the
  /// benchmark that measures what it saves).
  bool warm_up = true;
  /// Throws std::invalid_argument naming the bad flag (--backend, --gl-method,
  /// --refine, --threads, --gl-device).
  void Check() const;
};

/// The CPU reference backend: PlaneSweepCpu, ComputeHullVisibility and
/// TextureHull with `threads` row-band threads and `refine` bisections. Throws
/// std::invalid_argument for threads < 1 or refine < 0.
std::unique_ptr<SweepBackend> MakeCpuSweepBackend(int threads = 1, int refine = 0);

}  // namespace hullpipe
