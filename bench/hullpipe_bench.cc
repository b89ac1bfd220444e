// hullpipe_bench: times the per-frame algorithms on frame 200 of the real rig
// (or the synthetic scene with --synthetic) and prints a Markdown table:
// segmentation, CPU and GL plane sweeps at 320x240 and 640x480 with 50/100/200
// planes, texturing, and the triangle query (the paper's case: 720 triangles in
// 10x10 viewports). Each figure is the median of --repeats runs.
#include <algorithm>
#include <cstdio>
#include <functional>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "hullpipe/util/percentile.h"
#include "hullpipe/geometry/calibration.h"
#include "hullpipe/collision/collision.h"
#include "hullpipe/reconstruction/compositor.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/gl/egl_context.h"
#include "hullpipe/gl/gl_plane_sweep.h"
#include "hullpipe/gl/gl_triangle_query.h"
#include "hullpipe/geometry/mesh.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/segmentation/rig_source.h"
#include "hullpipe/segmentation/segmentation.h"
#include "hullpipe/reconstruction/texture.h"

using namespace hullpipe;

namespace {

double MedianMs(int repeats, const std::function<void()>& f) {
  std::vector<double> t;
  f();  // warm-up
  for (int i = 0; i < repeats; ++i) {
    const double t0 = MonotonicSeconds();
    f();
    t.push_back((MonotonicSeconds() - t0) * 1e3);
  }
  return Median(std::move(t));
}

void Row(const std::string& what, const std::string& config, double ms, const std::string& extra = "") {
  std::printf("| %-28s | %-34s | %9.2f | %-28s |\n", what.c_str(), config.c_str(), ms, extra.c_str());
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hullpipe_bench: per-frame algorithm timings"};
  std::string rig = HULLPIPE_RIG_DIR;
  bool synthetic = false, no_gl = false;
  int repeats = 7, frame = 200;
  app.add_option("--rig", rig, "Rig directory")->capture_default_str();
  app.add_flag("--synthetic", synthetic, "Use the synthetic scene instead of the rig");
  app.add_flag("--no-gl", no_gl, "Skip the GL rows");
  app.add_option("--repeats", repeats, "Runs per row (median)")->capture_default_str();
  app.add_option("--frame", frame, "Rig frame")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  spdlog::set_level(spdlog::level::warn);

  std::unique_ptr<RigSource> src;
  if (synthetic) {
    src = OpenSyntheticRig({});
    frame = 10;
  } else {
    src = OpenVideoRig(rig, {});
  }
  RigFrame f;
  for (int k = 0; k <= frame; ++k)
    if (!src->Next(&f)) {
      std::fprintf(stderr, "input too short\n");
      return 1;
    }
  std::vector<CameraMap> views;
  std::vector<CameraImage> images;
  for (size_t i = 0; i < src->cameras().size(); ++i) {
    views.push_back({src->cameras()[i], f.maps[i]});
    cv::Mat small;
    cv::resize(f.images[i], small, {}, 0.5, 0.5, cv::INTER_AREA);
    images.push_back({src->cameras()[i], small});
  }
  const VolumeQuery q(views, src->workspace());
  const Eigen::Vector3d centre = q.hull_box().Center();
  OrbitPath orbit;
  orbit.centre = centre;

  std::printf("| %-28s | %-34s | %9s | %-28s |\n", "stage", "configuration", "ms/frame", "notes");
  std::printf("|%s|%s|%s|%s|\n", std::string(30, '-').c_str(), std::string(36, '-').c_str(),
              std::string(11, '-').c_str(), std::string(30, '-').c_str());

  if (!synthetic) {
    // Segmentation of one 644x486 camera frame (the capture node does 4 per frame).
    const Rig r = LoadRig(rig);
    cv::VideoCapture bgcap(r.cameras[0].background);
    std::vector<cv::Mat> bg;
    cv::Mat img;
    while (bg.size() < 60 && bgcap.read(img)) bg.push_back(img.clone());
    const BackgroundModel model(bg);
    Row("segmentation (1 camera)", "644x486", MedianMs(repeats * 3, [&] { (void)model.Segment(f.images[0]); }));
  }

  std::optional<gl::EglContext> ctx;
  std::unique_ptr<gl::GlPlaneSweep> gl_sweep;
  std::unique_ptr<gl::GlTriangleQuery> gl_tri;
  if (!no_gl) {
    std::string why;
    ctx = gl::EglContext::TryCreate(&why);
    if (ctx) {
      gl_sweep = std::make_unique<gl::GlPlaneSweep>();
      gl_tri = std::make_unique<gl::GlTriangleQuery>();
    } else {
      std::fprintf(stderr, "no GL rows: %s\n", why.c_str());
    }
  }
  const std::string gl_name = ctx ? "GL (" + ctx->renderer().substr(0, ctx->renderer().find(' ')) + ")" : "";

  for (const auto& [w, h] : {std::pair{320, 240}, std::pair{640, 480}}) {
    const NovelView view = NovelView::FromFov(w, h, 50 * M_PI / 180, orbit.WorldFromEye(1.0));
    const cv::Rect full(0, 0, w, h);
    for (int planes : {50, 100, 200}) {
      PlaneSweepOptions o;
      o.num_planes = planes;
      const auto depths = SweepPlaneDepths(q, view, o);
      const std::string cfg = std::to_string(w) + "x" + std::to_string(h) + ", " + std::to_string(planes) + " planes";
      SweepStats st;
      PlaneSweepCpu(q, view, depths, full, &st);
      char note[64];
      std::snprintf(note, sizeof note, "%.1fk rays, %.0f planes/ray", st.rays / 1e3,
                    double(st.plane_points) / double(std::max<int64_t>(1, st.rays)));
      Row("plane sweep CPU, 1 thread", cfg, MedianMs(repeats, [&] { (void)PlaneSweepCpu(q, view, depths, full); }), note);
      Row("plane sweep CPU, half view", cfg + " (one recon tile)",
          MedianMs(repeats, [&] { (void)PlaneSweepCpu(q, view, depths, TileRect(0, 2, w, h)); }));
      Row("plane sweep CPU + refine 6", cfg + " (one recon tile)",
          MedianMs(repeats, [&] { (void)PlaneSweepCpu(q, view, depths, TileRect(0, 2, w, h), nullptr, 1, 6); }));
      if (gl_sweep)
        Row("plane sweep " + gl_name, cfg, MedianMs(std::max(3, repeats / 2), [&] { (void)gl_sweep->Sweep(q, view, depths, full); }));
    }
    const auto depths = SweepPlaneDepths(q, view, {});
    const cv::Mat d = PlaneSweepCpu(q, view, depths, full);
    Row("texture (2 best cameras)", std::to_string(w) + "x" + std::to_string(h),
        MedianMs(repeats, [&] { (void)TextureHull(d, full, view, images); }));
    if (w == 320) {
      std::vector<Camera> cams;
      for (const auto& im : images) cams.push_back(im.camera);
      PlaneSweepOptions vo;
      vo.num_planes = 48;
      Row("visibility maps (4 cameras)", "80 px across, 48 planes, refine 6",
          MedianMs(repeats, [&] { (void)ComputeHullVisibility(q, cams, 80, vo, 6); }));
      Row("visibility maps (4 cameras)", "80 px across, 48 planes, refine 0",
          MedianMs(repeats, [&] { (void)ComputeHullVisibility(q, cams, 80, vo, 0); }));
      const HullVisibility vis = ComputeHullVisibility(q, cams, 80, vo, 0);
      Row("texture with visibility", std::to_string(w) + "x" + std::to_string(h),
          MedianMs(repeats, [&] { (void)TextureHull(d, full, view, images, {}, &vis); }));
    }
    const cv::Mat colour(h, w, CV_8UC3, cv::Scalar(0));
    Row("composite", std::to_string(w) + "x" + std::to_string(h),
        MedianMs(repeats, [&] { (void)Composite(view, d, colour, {{centre, 0.12, false}}); }));
  }

  // Triangle query: the paper's curtain case, 720 triangles of ~2 cm at the hull,
  // each in a 10x10 viewport; and our default sizing (4 mm pixels).
  {
    std::vector<Triangle> tris;
    const double s = 0.02;
    for (int i = 0; tris.size() < 720; ++i) {
      const Eigen::Vector3d o = centre + Eigen::Vector3d((i % 24) * s - 0.24, 0.0, (i / 24) * s - 0.3);
      tris.push_back({o, o + Eigen::Vector3d(s, 0, 0), o + Eigen::Vector3d(0, 0, s)});
    }
    for (const TriangleQueryOptions& o : {TriangleQueryOptions{0.002, 10, 64}, TriangleQueryOptions{0.004, 0, 32}}) {
      const std::string cfg = o.fixed_viewport ? "720 tris, 10x10 viewports (paper)" : "720 tris, 4 mm pixels";
      size_t points = 0;
      const double ms = MedianMs(repeats, [&] {
        points = 0;
        for (const auto& t : tris) points += QueryTriangleCpu(q, t.a, t.b, t.c, o).collision_points.size();
      });
      char note[64];
      std::snprintf(note, sizeof note, "%.0f tris/s, %zu points", 720.0 / ms * 1e3, points);
      Row("triangle query CPU", cfg, ms, note);
      if (gl_tri) {
        const double gms = MedianMs(std::max(3, repeats / 2), [&] { (void)gl_tri->Query(q, tris, o); });
        std::snprintf(note, sizeof note, "%.0f tris/s", 720.0 / gms * 1e3);
        Row("triangle query " + gl_name, cfg, gms, note);
      }
    }
  }
  return 0;
}
