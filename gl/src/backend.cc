#include "hullpipe/gl/backend.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/geometry/mesh.h"
#include "hullpipe/gl/egl_context.h"
#include "hullpipe/gl/gl_plane_sweep.h"
#include "hullpipe/gl/gl_ray_sweep.h"
#include "hullpipe/gl/gl_triangle_query.h"
#include "hullpipe/gl/gl_texture.h"

namespace hullpipe::gl {
namespace {

// The synthetic frameset both start-up probes use (the triangle query's timing
// and the backend's warm-up frame): four cameras of w x h 3 m around a 0.3-m
// sphere at kProbeCentre, each map the sphere's exact silhouette (a pixel is
// object iff its ray meets the sphere).
const Eigen::Vector3d kProbeCentre(0, 0, -1);

std::vector<CameraMap> ProbeViews(int w, int h) {
  const Eigen::Vector3d centre = kProbeCentre;
  const double radius = 0.3;
  std::vector<CameraMap> views;
  for (int k = 0; k < 4; ++k) {
    const double a = 2 * M_PI * k / 4;
    Camera c;
    c.id = k + 1;
    c.width = w, c.height = h;
    c.fx = c.fy = 300.0 * w / 320, c.cx = w / 2.0, c.cy = h / 2.0;
    c.cam_from_world =
        LookAt(centre + Eigen::Vector3d(3 * std::cos(a), 3 * std::sin(a), -1.0), centre, Eigen::Vector3d(0, 0, -1))
            .Inverse();
    cv::Mat map(c.height, c.width, CV_8UC1, cv::Scalar(0));
    const Eigen::Vector3d o = c.Center();
    for (int v = 0; v < c.height; ++v)
      for (int u = 0; u < c.width; ++u) {
        const Eigen::Vector3d d = c.PixelRayWorld({u + 0.5, v + 0.5});
        const double t = (centre - o).dot(d);
        map.at<uint8_t>(v, u) = t > 0 && (o + t * d - centre).norm() < radius ? 255 : 0;
      }
    views.push_back({c, map});
  }
  return views;
}

class GlBackend final : public SweepBackend {
 public:
  GlBackend(EglContext ctx, bool stencil, int threads, int refine, bool warm_up)
      : ctx_(std::move(ctx)), stencil_(stencil), refine_(refine) {
    set_threads(threads);
    // The programs are built here, with the context current: a driver that cannot
    // build them fails now, where `auto` can still fall back.
    if (stencil_) stencil_sweep_ = std::make_unique<GlPlaneSweep>();
    march_ = std::make_unique<GlRaySweep>();
    texture_ = std::make_unique<GlTexture>();
    if (warm_up) WarmUp();
  }
  // One small frame through every pass (upload, visibility maps, march and
  // silhouette pass, texture, read-backs): a driver may finish compiling a
  // program at its first dispatch, and the first frameset a node renders should
  // not pay for it (the first framesets were each run's slowest on a GPU).
  void WarmUp() {
    const std::vector<CameraMap> views = ProbeViews(64, 48);
    Aabb ws;
    ws.min = kProbeCentre - Eigen::Vector3d::Constant(1.0), ws.max = kProbeCentre + Eigen::Vector3d::Constant(1.0);
    const VolumeQuery q(views, ws);
    std::vector<CameraImage> images;
    std::vector<Camera> cams;
    for (const CameraMap& v : views) {
      cv::Mat img;
      cv::cvtColor(v.map, img, cv::COLOR_GRAY2BGR);
      images.push_back({v.camera, img});
      cams.push_back(v.camera);
    }
    const NovelView view = NovelView::FromFov(
        32, 24, 0.5, LookAt(kProbeCentre + Eigen::Vector3d(2, 0, -0.5), kProbeCentre, Eigen::Vector3d(0, 0, -1)));
    PlaneSweepOptions o;
    o.num_planes = 16;
    BeginFrameset(q, images);
    ComputeVisibility(q, cams, 16, o);
    (void)SweepTextured(q, view, SweepPlaneDepths(q, view, o), cv::Rect(0, 0, view.width, view.height), images, true,
                        nullptr);
    ForgetFrameset();  // nothing of the probe is kept for a real frameset
  }
  void BeginFrameset(const VolumeQuery& q, const std::vector<CameraImage>& images) override {
    ctx_.MakeCurrent();
    march_->Upload(q);
    // Only what a hull point can project to: each image around its camera's
    // object pixels (the texture pass uploads an image whole if it reads past).
    const std::vector<cv::Rect> rects = GlTexture::ObjectImageRects(q, images);
    texture_->UploadImages(images, &rects);
    ForgetFrameset();
  }
  // The last frameset's visibility maps and tile are no longer this one's.
  void ForgetFrameset() {
    vis_views_.clear();
    has_vis_ = false;
    last_tile_ = cv::Mat();
  }
  cv::Mat Sweep(const VolumeQuery& q, const NovelView& v, const std::vector<double>& d, const cv::Rect& tile,
                SweepStats* stats) override {
    ctx_.MakeCurrent();
    const double t0 = MonotonicSeconds();
    cv::Mat depth = stencil_ ? stencil_sweep_->Sweep(q, v, d, tile) : march_->Sweep(q, v, d, tile, refine_);
    // The march's tile stays on the GPU for the texture pass (Texture checks
    // it is given this very Mat).
    last_tile_ = stencil_ ? cv::Mat() : depth;
    const double t1 = MonotonicSeconds();
    // The stencil sweep's bracket is refined with CPU point queries.
    if (stencil_) RefineSweepDepth(q, v, d, tile, refine_, &depth, threads(), stop());
    if (stats) {
      stats->sweep_ms += (t1 - t0) * 1e3;
      stats->refine_ms += (MonotonicSeconds() - t1) * 1e3;
    }
    return depth;
  }
  void ComputeVisibility(const VolumeQuery& q, const std::vector<Camera>& cams, int width,
                         const PlaneSweepOptions& sweep) override {
    ctx_.MakeCurrent();
    vis_views_.clear();
    std::vector<std::vector<double>> depths;
    for (const Camera& cam : cams) {
      vis_views_.push_back(HullVisibilityView(cam, width));
      depths.push_back(SweepPlaneDepths(q, vis_views_.back(), sweep));
    }
    march_->SweepViews(q, vis_views_, depths, refine_);
    has_vis_ = true;
  }
  HullVisibility KeptVisibility() override {
    ctx_.MakeCurrent();
    HullVisibility vis;
    vis.views = vis_views_;
    for (size_t k = 0; k < vis_views_.size(); ++k) vis.depth.push_back(march_->ReadView(k));
    return vis;
  }
  cv::Mat Texture(const cv::Mat& depth, const cv::Rect& tile, const NovelView& view,
                  const std::vector<CameraImage>& images, bool with_visibility) override {
    ctx_.MakeCurrent();
    if (!with_visibility) return texture_->Texture(depth, tile, view, images, {}, nullptr);
    if (!has_vis_) throw std::logic_error("Texture with visibility before ComputeVisibility");
    const bool on_gpu = !last_tile_.empty() && depth.data == last_tile_.data && depth.size() == last_tile_.size();
    return texture_->Texture(depth, tile, view, images, {}, vis_views_, march_->views_texture(),
                             on_gpu ? march_->tile_texture() : 0);
  }
  TexturedTile SweepTextured(const VolumeQuery& q, const NovelView& v, const std::vector<double>& d,
                             const cv::Rect& tile, const std::vector<CameraImage>& images, bool with_visibility,
                             SweepStats* stats) override {
    // The stencil method refines on the CPU between its pass and the texture.
    if (stencil_) return SweepBackend::SweepTextured(q, v, d, tile, images, with_visibility, stats);
    ctx_.MakeCurrent();
    if (with_visibility && !has_vis_) throw std::logic_error("Texture with visibility before ComputeVisibility");
    const double t0 = MonotonicSeconds();
    TexturedTile out;
    const std::vector<NovelView>* vis_views = with_visibility ? &vis_views_ : nullptr;
    const GLuint vis_texture = with_visibility ? march_->views_texture() : 0;
    // Both passes queued, then one wait: the texture reads the tile's depth
    // where the march left it. A tile the march dispatched nothing for (all
    // kNoDepth) is read first and uploaded to the texture pass instead.
    const bool swept = march_->SweepOnGpu(q, v, d, tile, refine_);
    if (swept) texture_->Dispatch(tile, v, images, {}, vis_views, vis_texture, march_->tile_texture());
    out.depth = march_->ReadTile();
    if (!swept) texture_->Dispatch(tile, v, images, {}, vis_views, vis_texture, 0, &out.depth);
    const double t1 = MonotonicSeconds();
    const int64_t refetched = texture_->refetched_images();
    out.colour = texture_->ReadBack();
    out.refetched_images = int(texture_->refetched_images() - refetched);
    out.texture_ms = (MonotonicSeconds() - t1) * 1e3;
    if (stats) stats->sweep_ms += (t1 - t0) * 1e3;
    last_tile_ = out.depth;
    return out;
  }
  std::string Name() const override {
    return std::string("gl ") + (stencil_ ? "stencil" : "march") + " (" + ctx_.renderer() + ")";
  }
  std::string GlSummary() const override { return ctx_.info().Summary(); }
  void Finish() override {
    ctx_.MakeCurrent();
    glFinish();
  }
  const GlInfo& info() const { return ctx_.info(); }

 private:
  EglContext ctx_;
  bool stencil_;
  int refine_;
  std::unique_ptr<GlPlaneSweep> stencil_sweep_;
  std::unique_ptr<GlRaySweep> march_;
  std::unique_ptr<GlTexture> texture_;
  std::vector<NovelView> vis_views_;  // the visibility maps' views (their depths on the GPU)
  cv::Mat last_tile_;                 // the last tile the march returned (its depth also on the GPU)
  bool has_vis_ = false;
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
    auto b = std::make_unique<GlBackend>(std::move(*ctx), o.gl_method == "stencil", o.threads, o.refine,
                                         o.warm_up);
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

namespace {

// What a triangle query costs on this machine for a batch of n triangles,
// fitted as fixed + n * per_triangle from two timed batches.
struct QueryCost {
  double fixed_ms = 0, per_triangle_ms = 0;
  double At(size_t n) const { return fixed_ms + double(n) * per_triangle_ms; }
};

// Times both queries on the same synthetic frameset (four cameras around a
// sphere, an icosphere cutting it: triangles inside, outside and across) at
// 80 and 5,120 triangles, medians of three after a warm-up.
void Calibrate(GlTriangleQuery& gl, int cpu_threads, QueryCost* gpu, QueryCost* cpu) {
  const Eigen::Vector3d centre = kProbeCentre;
  const std::vector<CameraMap> views = ProbeViews(320, 240);
  Aabb ws;
  ws.min = centre - Eigen::Vector3d::Constant(1.0), ws.max = centre + Eigen::Vector3d::Constant(1.0);
  const VolumeQuery q(views, ws);
  const TriangleQueryOptions o{0.004, 0, 32};
  auto batch = [&](int subdivisions) {
    Rigid3d pose;
    pose.translation = centre + Eigen::Vector3d(0.2, 0, 0);
    const TriangleMesh m = TriangleMesh::Icosphere(0.25, subdivisions).Transformed(pose);
    std::vector<Triangle> tris;
    for (const auto& t : m.triangles)
      tris.push_back({m.vertices[size_t(t[0])], m.vertices[size_t(t[1])], m.vertices[size_t(t[2])]});
    return tris;
  };
  auto median_ms = [](const std::function<void()>& f) {
    f();
    std::vector<double> t;
    for (int i = 0; i < 3; ++i) {
      const double t0 = MonotonicSeconds();
      f();
      t.push_back((MonotonicSeconds() - t0) * 1e3);
    }
    std::sort(t.begin(), t.end());
    return t[1];
  };
  const std::vector<Triangle> small = batch(1), large = batch(4);  // 80 and 5,120
  double g[2], c[2];
  int k = 0;
  for (const auto* tris : {&small, &large}) {
    g[k] = median_ms([&] { (void)gl.QueryBatch(q, *tris, o).All(); });
    c[k] = median_ms([&] { (void)QueryTrianglesCpu(q, *tris, o, cpu_threads); });
    ++k;
  }
  const double dn = double(large.size() - small.size());
  *gpu = {std::max(0.0, g[0] - (g[1] - g[0]) / dn * double(small.size())), std::max(0.0, (g[1] - g[0]) / dn)};
  *cpu = {std::max(0.0, c[0] - (c[1] - c[0]) / dn * double(small.size())), std::max(0.0, (c[1] - c[0]) / dn)};
}

}  // namespace

namespace {

// The GL query on its own context, as a TriangleQueryFunction (the context
// made current on each call).
struct GlQuery {
  EglContext ctx;
  std::unique_ptr<GlTriangleQuery> query;
};

std::shared_ptr<GlQuery> BuildGlQuery(EglContext ctx) {
  auto gl = std::make_shared<GlQuery>(GlQuery{std::move(ctx), nullptr});
  gl->ctx.MakeCurrent();
  gl->query = std::make_unique<GlTriangleQuery>();  // built with the context current
  return gl;
}

TriangleQueryFunction OnGpu(std::shared_ptr<GlQuery> gl) {
  return [gl](const VolumeQuery& q, const std::vector<Triangle>& tris, const TriangleQueryOptions& o) {
    gl->ctx.MakeCurrent();
    return gl->query->Query(q, tris, o);
  };
}

}  // namespace

TriangleQueryFunction MeasuredTriangleQuery(EglContext ctx, int cpu_threads, std::string* description) {
  if (cpu_threads < 1) throw std::invalid_argument("MeasuredTriangleQuery: cpu_threads must be >= 1");
  const std::string summary = ctx.info().Summary();
  const std::shared_ptr<GlQuery> gl = BuildGlQuery(std::move(ctx));
  QueryCost gpu, cpu;
  Calibrate(*gl->query, cpu_threads, &gpu, &cpu);
  char line[256];
  std::snprintf(line, sizeof line, "GL %.2f ms + %.2f us a triangle, CPU (%d thread%s) %.2f ms + %.2f us",
                gpu.fixed_ms, gpu.per_triangle_ms * 1e3, cpu_threads, cpu_threads == 1 ? "" : "s", cpu.fixed_ms,
                cpu.per_triangle_ms * 1e3);
  auto say = [&](const std::string& s) {
    if (description) *description = s;
  };
  // Both costs are linear in the batch's size: the GPU is faster for some
  // batch of 1 to 10^6 triangles iff it is at one end.
  if (gpu.At(1) >= cpu.At(1) && gpu.At(1000000) >= cpu.At(1000000)) {
    say(std::string("cpu (auto: measured ") + line + ")");
    return {};
  }
  say("gl triangle query where faster for the batch (auto: measured " + std::string(line) + "; " + summary + ")");
  return [on_gpu = OnGpu(gl), gpu, cpu, cpu_threads](const VolumeQuery& q, const std::vector<Triangle>& tris,
                                                     const TriangleQueryOptions& o) {
    if (gpu.At(tris.size()) < cpu.At(tris.size())) return on_gpu(q, tris, o);
    return QueryTrianglesCpu(q, tris, o, cpu_threads);
  };
}

TriangleQueryFunction MakeTriangleQuery(const std::string& name, const EglOptions& egl, std::string* description,
                                        int cpu_threads) {
  auto say = [&](const std::string& s) {
    if (description) *description = s;
  };
  if (name != "cpu" && name != "gl" && name != "auto")
    throw std::invalid_argument("--backend must be cpu, gl or auto, not '" + name + "'");
  if (cpu_threads < 1) throw std::invalid_argument("MakeTriangleQuery: cpu_threads must be >= 1");
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
  const std::string summary = ctx->info().Summary();
  try {
    // auto on a hardware renderer: whichever is faster for a batch's size on
    // this machine, from both timed at the start.
    if (name == "auto") return MeasuredTriangleQuery(std::move(*ctx), cpu_threads, description);
    TriangleQueryFunction f = OnGpu(BuildGlQuery(std::move(*ctx)));
    say("gl triangle query (" + summary + ")");
    return f;
  } catch (const std::exception& e) {
    if (name == "gl") throw std::runtime_error(std::string("--backend gl: ") + e.what());
    say(std::string("cpu (auto: GL triangle query failed to build: ") + e.what() + ")");
    return {};
  }
}

}  // namespace hullpipe::gl
