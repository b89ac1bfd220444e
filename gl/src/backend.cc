#include "hullpipe/gl/backend.h"

#include <algorithm>
#include <cstdio>
#include <functional>
#include <stdexcept>

#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/geometry/mesh.h"
#include "hullpipe/gl/egl_context.h"
#include "hullpipe/gl/gl_plane_sweep.h"
#include "hullpipe/gl/gl_ray_sweep.h"
#include "hullpipe/gl/gl_triangle_query.h"
#include "hullpipe/gl/gl_texture.h"

namespace hullpipe::gl {
namespace {

class GlBackend final : public SweepBackend {
 public:
  GlBackend(EglContext ctx, bool stencil, int threads, int refine)
      : ctx_(std::move(ctx)), stencil_(stencil), refine_(refine) {
    set_threads(threads);
    // The programs are built here, with the context current: a driver that cannot
    // build them fails now, where `auto` can still fall back.
    if (stencil_) stencil_sweep_ = std::make_unique<GlPlaneSweep>();
    march_ = std::make_unique<GlRaySweep>();
    texture_ = std::make_unique<GlTexture>();
  }
  void BeginFrameset(const VolumeQuery& q, const std::vector<CameraImage>& images) override {
    ctx_.MakeCurrent();
    march_->Upload(q);
    texture_->UploadImages(images);
    vis_views_.clear();
    has_vis_ = false;
  }
  cv::Mat Sweep(const VolumeQuery& q, const NovelView& v, const std::vector<double>& d, const cv::Rect& tile,
                SweepStats* stats) override {
    ctx_.MakeCurrent();
    const double t0 = MonotonicSeconds();
    cv::Mat depth = stencil_ ? stencil_sweep_->Sweep(q, v, d, tile) : march_->Sweep(q, v, d, tile, refine_);
    const double t1 = MonotonicSeconds();
    // The stencil sweep's bracket is refined with CPU point queries.
    if (stencil_) RefineSweepDepth(q, v, d, tile, refine_, &depth, threads(), stop());
    if (stats) {
      stats->sweep_ms += (t1 - t0) * 1e3;
      stats->refine_ms += (MonotonicSeconds() - t1) * 1e3;
    }
    return depth;
  }
  HullVisibility Visibility(const VolumeQuery& q, const std::vector<Camera>& cams, int width,
                            const PlaneSweepOptions& sweep) override {
    ctx_.MakeCurrent();
    HullVisibility vis;
    for (const Camera& cam : cams) {
      NovelView v = HullVisibilityView(cam, width);
      const auto depths = SweepPlaneDepths(q, v, sweep);
      vis.depth.push_back(march_->Sweep(q, v, depths, {0, 0, v.width, v.height}, refine_));
      vis.views.push_back(v);
    }
    return vis;
  }
  cv::Mat Texture(const cv::Mat& depth, const cv::Rect& tile, const NovelView& view,
                  const std::vector<CameraImage>& images, const HullVisibility* vis) override {
    ctx_.MakeCurrent();
    return texture_->Texture(depth, tile, view, images, {}, vis);
  }
  std::string Name() const override {
    return std::string("gl ") + (stencil_ ? "stencil" : "march") + " (" + ctx_.renderer() + ")";
  }
  std::string GlSummary() const override { return ctx_.info().Summary(); }
  const GlInfo& info() const { return ctx_.info(); }

 private:
  EglContext ctx_;
  bool stencil_;
  int refine_;
  std::unique_ptr<GlPlaneSweep> stencil_sweep_;
  std::unique_ptr<GlRaySweep> march_;
  std::unique_ptr<GlTexture> texture_;
};

// The GL context a backend `name` (gl|auto) gets, or nullopt with *why saying
// why the CPU `what` runs instead ("auto: ..."); "gl" without a context throws.
// What the sweep and the models' triangle query both decide.
std::optional<EglContext> ContextFor(const std::string& name, const EglOptions& egl, const std::string& what,
                                     std::string* why) {
  std::string failed;
  std::optional<EglContext> ctx = EglContext::TryCreate(egl, &failed);
  if (!ctx) {
    if (name == "gl") throw std::runtime_error("--backend gl: no GL context: " + failed);
    *why = "auto: no GL context (" + failed + "); the CPU " + what;
    return std::nullopt;
  }
  if (name == "auto" && ctx->IsSoftware()) {
    *why = "auto: GL renderer is software (" + ctx->renderer() + "); the CPU " + what + " is faster there";
    return std::nullopt;
  }
  return ctx;
}

}  // namespace

std::unique_ptr<SweepBackend> MakeSweepBackend(const BackendOptions& o) {
  o.Check();
  auto cpu = [&](const std::string& why) {
    auto b = MakeCpuSweepBackend(o.threads, o.refine);
    b->set_reason(why);
    return b;
  };
  if (o.name == "cpu") return cpu("--backend cpu");
  std::string why;
  std::optional<EglContext> ctx = ContextFor(o.name, EglOptions{o.gl_device}, "sweep", &why);
  if (!ctx) return cpu(why);
  const std::string summary = ctx->info().Summary();
  try {
    auto b = std::make_unique<GlBackend>(std::move(*ctx), o.gl_method == "stencil", o.threads, o.refine);
    b->set_reason((o.name == "auto" ? "auto: hardware GL renderer " : "--backend gl: ") + summary);
    return b;
  } catch (const std::exception& e) {
    if (o.name == "gl") throw std::runtime_error(std::string("--backend gl: ") + e.what());
    return cpu(std::string("auto: GL programs failed (") + e.what() + "); the CPU sweep");
  }
}

std::unique_ptr<SweepBackend> MakeSweepBackend(const std::string& name, int threads, int refine) {
  BackendOptions o;
  o.name = name;
  o.threads = threads;
  o.refine = refine;
  return MakeSweepBackend(o);
}

const GlInfo* GlInfoOf(const SweepBackend& backend) {
  const auto* gl = dynamic_cast<const GlBackend*>(&backend);
  return gl ? &gl->info() : nullptr;
}

TriangleQueryFunction MakeTriangleQuery(const std::string& name, const EglOptions& egl, std::string* description) {
  auto say = [&](const std::string& s) {
    if (description) *description = s;
  };
  if (name != "cpu" && name != "gl" && name != "auto")
    throw std::invalid_argument("--backend must be cpu, gl or auto, not '" + name + "'");
  if (name == "cpu") {
    say("cpu (--backend cpu)");
    return {};
  }
  std::string why;
  std::optional<EglContext> ctx = ContextFor(name, egl, "triangle query", &why);
  if (!ctx) {
    say("cpu (" + why + ")");
    return {};
  }
  struct Gl {
    EglContext ctx;
    GlTriangleQuery query;
  };
  std::shared_ptr<Gl> gl;
  const std::string summary = ctx->info().Summary();
  try {
    gl = std::make_shared<Gl>(Gl{std::move(*ctx), GlTriangleQuery()});  // built with the context current
  } catch (const std::exception& e) {
    if (name == "gl") throw std::runtime_error(std::string("--backend gl: ") + e.what());
    say(std::string("cpu (auto: GL triangle query failed to build: ") + e.what() + ")");
    return {};
  }
  say("gl triangle query (" + summary + ")");
  return [gl](const VolumeQuery& q, const std::vector<Triangle>& tris, const TriangleQueryOptions& o) {
    gl->ctx.MakeCurrent();
    return gl->query.Query(q, tris, o);
  };
}

}  // namespace hullpipe::gl
