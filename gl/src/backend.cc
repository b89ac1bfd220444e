#include "hullpipe/gl/backend.h"

#include <stdexcept>

#include <spdlog/spdlog.h>

#include "hullpipe/gl/egl_context.h"
#include "hullpipe/gl/gl_plane_sweep.h"
#include "hullpipe/gl/gl_triangle_query.h"

namespace hullpipe::gl {
namespace {

class CpuBackend final : public SweepBackend {
 public:
  CpuBackend(int threads, int refine) : threads_(threads), refine_(refine) {}
  cv::Mat Sweep(const VolumeQuery& q, const NovelView& v, const std::vector<double>& d,
                const cv::Rect& tile) override {
    return PlaneSweepCpu(q, v, d, tile, nullptr, threads_, refine_);
  }
  std::string Name() const override { return "cpu"; }

 private:
  int threads_, refine_;
};

class GlBackend final : public SweepBackend {
 public:
  GlBackend(EglContext ctx, int threads, int refine) : ctx_(std::move(ctx)), threads_(threads), refine_(refine) {}
  cv::Mat Sweep(const VolumeQuery& q, const NovelView& v, const std::vector<double>& d,
                const cv::Rect& tile) override {
    ctx_.MakeCurrent();
    cv::Mat depth = sweep_.Sweep(q, v, d, tile);
    RefineSweepDepth(q, v, d, tile, refine_, &depth, threads_);  // CPU point queries on the GPU's bracket
    return depth;
  }
  std::string Name() const override { return "gl (" + ctx_.renderer() + ")"; }

 private:
  EglContext ctx_;
  int threads_, refine_;
  GlPlaneSweep sweep_;  // constructed after ctx_ is current
};

}  // namespace

std::unique_ptr<SweepBackend> MakeSweepBackend(const std::string& name, int threads, int refine) {
  if (refine < 0) throw std::invalid_argument("refine iterations must be >= 0");
  if (name == "cpu") return std::make_unique<CpuBackend>(threads, refine);
  if (name != "gl" && name != "auto") throw std::invalid_argument("unknown backend '" + name + "'");
  std::string why;
  std::optional<EglContext> ctx = EglContext::TryCreate(&why);
  if (!ctx) {
    if (name == "gl") throw std::runtime_error("--backend gl: " + why);
    spdlog::info("auto backend: {}; using the CPU sweep", why);
    return std::make_unique<CpuBackend>(threads, refine);
  }
  if (name == "auto" && ctx->IsSoftware()) {
    spdlog::info("auto backend: GL renderer is software ({}); the CPU sweep is faster there", ctx->renderer());
    return std::make_unique<CpuBackend>(threads, refine);
  }
  return std::make_unique<GlBackend>(std::move(*ctx), threads, refine);
}

}  // namespace hullpipe::gl
