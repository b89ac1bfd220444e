#include "hullpipe/reconstruction/sweep_backend.h"

#include <stdexcept>

#include "hullpipe/geometry/conventions.h"

namespace hullpipe {
namespace {

class CpuBackend final : public SweepBackend {
 public:
  CpuBackend(int threads, int refine) : refine_(refine) { set_threads(threads); }
  void BeginFrameset(const VolumeQuery&, const std::vector<CameraImage>&) override {
    vis_ = {};
    has_vis_ = false;
  }
  cv::Mat Sweep(const VolumeQuery& q, const NovelView& v, const std::vector<double>& d, const cv::Rect& tile,
                SweepStats* stats) override {
    return PlaneSweepCpu(q, v, d, tile, stats, threads(), refine_, stop());
  }
  void ComputeVisibility(const VolumeQuery& q, const std::vector<Camera>& cams, int width,
                         const PlaneSweepOptions& sweep) override {
    vis_ = ComputeHullVisibility(q, cams, width, sweep, refine_, threads(), stop());
    has_vis_ = true;
  }
  HullVisibility KeptVisibility() override { return vis_; }
  cv::Mat Texture(const cv::Mat& depth, const cv::Rect& tile, const NovelView& view,
                  const std::vector<CameraImage>& images, bool with_visibility) override {
    if (with_visibility && !has_vis_) throw std::logic_error("Texture with visibility before ComputeVisibility");
    return TextureHull(depth, tile, view, images, {}, with_visibility ? &vis_ : nullptr, stop(), threads());
  }
  std::string Name() const override { return "cpu"; }

 private:
  int refine_;
  HullVisibility vis_;
  bool has_vis_ = false;
};

}  // namespace

TexturedTile SweepBackend::SweepTextured(const VolumeQuery& query, const NovelView& view,
                                         const std::vector<double>& depths, const cv::Rect& tile,
                                         const std::vector<CameraImage>& images, bool with_visibility,
                                         SweepStats* stats) {
  TexturedTile out;
  out.depth = Sweep(query, view, depths, tile, stats);
  const double t0 = MonotonicSeconds();
  out.colour = Texture(out.depth, tile, view, images, with_visibility);
  out.texture_ms = (MonotonicSeconds() - t0) * 1e3;
  return out;
}

void BackendOptions::Check() const {
  if (name != "cpu" && name != "gl" && name != "auto")
    throw std::invalid_argument("--backend: unknown backend '" + name + "' (cpu, gl or auto)");
  if (gl_method != "march" && gl_method != "stencil")
    throw std::invalid_argument("--gl-method: unknown method '" + gl_method + "' (march or stencil)");
  if (refine < 0) throw std::invalid_argument("--refine: refine iterations must be >= 0");
  if (threads < 1) throw std::invalid_argument("--threads: must be >= 1");
  if (gl_device < -1) throw std::invalid_argument("--gl-device: must be >= 0 (or -1 to pick)");
}

std::unique_ptr<SweepBackend> MakeCpuSweepBackend(int threads, int refine) {
  if (threads < 1) throw std::invalid_argument("--threads: must be >= 1");
  if (refine < 0) throw std::invalid_argument("--refine: refine iterations must be >= 0");
  return std::make_unique<CpuBackend>(threads, refine);
}

}  // namespace hullpipe
