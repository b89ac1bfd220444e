// vh_eval sweep: the plane sweep's speed against its error, on synthetic scenes
// with exact object-pixel maps, against the exact visual hull (paper §3.3; docs/benchmarks.md).
#include "vh_eval_sweep.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <tuple>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/util/percentile.h"
#include "hullpipe/geometry/calibration.h"
#include "hullpipe/evaluation/depth_eval.h"
#include "hullpipe/reconstruction/exact_hull.h"
#include "hullpipe/gl/egl_context.h"
#include "hullpipe/gl/gl_plane_sweep.h"
#include "hullpipe/gl/gl_triangle_query.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/reconstruction/texture.h"
#include "hullpipe/util/logging.h"

namespace hullpipe {
namespace {

using Clock = std::chrono::steady_clock;

struct Config {
  int planes = 64;
  PlaneSpacing spacing = PlaneSpacing::kUniformDepth;
  int width = 320, height = 240;
  int cameras = 4;
  std::string backend = "cpu";
  int refine = 0;
  std::string distortion = "none";  // none | corrected | ignored
};

// One (cameras, view size, distortion) setting: maps, queries and references.
struct Setting {
  std::vector<Camera> true_cams;
  std::vector<cv::Mat> maps;
  std::optional<VolumeQuery> query;          // with the cameras' true model
  std::optional<VolumeQuery> query_ignored;  // distortion ignored (distorted settings only)
  NovelView view;
  cv::Mat exact;   // exact hull depth (true model)
  cv::Mat shapes;  // true shape depth
  DepthComparison hull_vs_shapes;
  double exact_seconds = 0;
};

const Distortion kLensDistortion{-0.25, 0.08, 0.001, -0.001, -0.01};

// The point nearest (least squares) to every camera's optical axis: where a
// rig's cameras look.
Eigen::Vector3d WhereCamerasLook(const std::vector<Camera>& cams) {
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const auto& c : cams) {
    const Eigen::Vector3d axis = c.cam_from_world.rotation.row(2).transpose();
    const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - axis * axis.transpose();
    A += P;
    b += P * c.Center();
  }
  return A.ldlt().solve(b);
}

Setting MakeSetting(const SweepEvalOptions& o, int cameras, int width, int height, bool distorted) {
  Setting s;
  SyntheticScene scene = NamedScene(o.scene, o.time_s);
  Eigen::Vector3d target = o.scene == "figure" ? Eigen::Vector3d(0, 0, -0.9) : Eigen::Vector3d(0, 0, -1.0);
  const Distortion d = distorted ? kLensDistortion : Distortion{};
  if (o.placement == "rig") {
    // The real rig's cameras (their own intrinsics and distortion); the scene is
    // moved to where they look, kept 1 m above the floor (z down, floor z = 0).
    s.true_cams = LoadRig(o.rig).Cameras();
    Eigen::Vector3d look = WhereCamerasLook(s.true_cams);
    look.z() = std::min(look.z(), -1.0);
    for (auto& sh : scene.shapes) {
      sh.a += look - target;
      sh.b += look - target;
    }
    target = look;
  } else {
    s.true_cams = o.placement == "ring"
                      ? RingCameras(cameras, 3.0, 1.8, target, o.camera_width, o.camera_height, 0.9, d)
                      : DomeCameras(cameras, 3.0, target, o.camera_width, o.camera_height, 0.9, d);
  }
  std::vector<CameraMap> views, ignored;
  for (const auto& c : s.true_cams) {
    s.maps.push_back(RenderExactMap(c, scene));
    views.push_back({c, s.maps.back()});
    Camera pinhole = c;
    pinhole.distortion = {};
    ignored.push_back({pinhole, s.maps.back()});
  }
  Aabb ws;
  ws.min = target - Eigen::Vector3d::Constant(1.2);
  ws.max = target + Eigen::Vector3d::Constant(1.2);
  s.query.emplace(views, ws);
  if (distorted) s.query_ignored.emplace(ignored, ws);
  const double dist = o.scene == "hand" ? 0.9 : o.scene == "figure" ? 4.5 : 2.2;
  const double hfov = o.scene == "figure" ? 0.5 : 0.55;
  const Eigen::Vector3d eye =
      target + dist * Eigen::Vector3d(std::cos(0.44) * std::cos(0.7), std::cos(0.44) * std::sin(0.7), -std::sin(0.44));
  s.view = NovelView::FromFov(width, height, hfov, LookAt(eye, target, Eigen::Vector3d(0, 0, -1)));
  const auto t0 = Clock::now();
  s.exact = ExactHullDepth(*s.query, s.view, {0, 0, width, height}, o.threads_reference);
  s.exact_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  s.shapes = SceneDepth(scene, s.view);
  s.hull_vs_shapes = CompareDepth(s.exact, s.shapes);
  return s;
}

std::vector<Config> StandardGrid(bool gl) {
  std::vector<Config> g;
  auto add = [&](Config c) {
    if (c.backend == "gl" && !gl) return;
    g.push_back(c);
  };
  // The core: 320x240, 4 cameras, every plane count and spacing, with and without refinement.
  for (int planes : {16, 32, 64, 128, 256, 512})
    for (PlaneSpacing sp : {PlaneSpacing::kUniformDepth, PlaneSpacing::kUniformInverseDepth})
      for (int refine : {0, 8}) add({planes, sp, 320, 240, 4, "cpu", refine, "none"});
  for (int planes : {16, 32, 64, 128})
    for (int refine : {0, 8}) add({planes, PlaneSpacing::kUniformDepth, 320, 240, 4, "gl", refine, "none"});
  // View sizes.
  for (auto [w, h] : {std::pair{160, 120}, std::pair{640, 480}})
    for (int planes : {32, 128})
      for (int refine : {0, 8}) add({planes, PlaneSpacing::kUniformDepth, w, h, 4, "cpu", refine, "none"});
  add({32, PlaneSpacing::kUniformDepth, 160, 120, 4, "gl", 0, "none"});
  add({128, PlaneSpacing::kUniformDepth, 160, 120, 4, "gl", 0, "none"});
  add({32, PlaneSpacing::kUniformDepth, 640, 480, 4, "gl", 0, "none"});
  // Camera counts.
  for (int cams : {8, 16}) {
    for (int planes : {32, 128})
      for (int refine : {0, 8}) add({planes, PlaneSpacing::kUniformDepth, 320, 240, cams, "cpu", refine, "none"});
    add({32, PlaneSpacing::kUniformDepth, 320, 240, cams, "gl", 0, "none"});
  }
  // Lens distortion, corrected and ignored.
  for (const char* d : {"corrected", "ignored"})
    for (int planes : {32, 128})
      for (int refine : {0, 8}) add({planes, PlaneSpacing::kUniformDepth, 320, 240, 4, "cpu", refine, d});
  return g;
}

std::vector<Config> FullGrid(bool gl) {
  std::vector<Config> g;
  for (const char* backend : {"cpu", "gl"}) {
    if (std::string(backend) == "gl" && !gl) continue;
    for (int cams : {4, 8, 16})
      for (auto [w, h] : {std::pair{160, 120}, std::pair{320, 240}, std::pair{640, 480}})
        for (int planes : {16, 32, 64, 128, 256, 512})
          for (PlaneSpacing sp : {PlaneSpacing::kUniformDepth, PlaneSpacing::kUniformInverseDepth})
            for (int refine : {0, 8}) g.push_back({planes, sp, w, h, cams, backend, refine, "none"});
  }
  return g;
}

const char* SpacingName(PlaneSpacing s) {
  return s == PlaneSpacing::kUniformDepth ? "uniform" : "inverse";
}

}  // namespace

int RunSweepEval(const SweepEvalOptions& o) {
  std::optional<gl::EglContext> ctx;
  std::optional<gl::GlPlaneSweep> gl_sweep;
  if (o.gl) {
    std::string why;
    ctx = gl::EglContext::TryCreate(&why);
    if (ctx) {
      gl_sweep.emplace();
    } else {
      std::fprintf(stderr, "vh_eval sweep: no GL rows: %s\n", why.c_str());
    }
  }
  std::vector<Config> grid = o.full ? FullGrid(bool(ctx)) : StandardGrid(bool(ctx));
  if (o.smoke) {
    // A few seconds' worth, for tests: 160x120, 4 cameras, 16 and 64 planes.
    grid.clear();
    for (int planes : {16, 64})
      for (int refine : {0, 8})
        grid.push_back({planes, PlaneSpacing::kUniformDepth, 160, 120, 4, "cpu", refine, "none"});
    if (ctx) grid.push_back({16, PlaneSpacing::kUniformDepth, 160, 120, 4, "gl", 0, "none"});
  }
  if (o.placement == "rig") {
    // The rig fixes the cameras (count, size, distortion): its rows are the
    // headline ones with its own camera count, distortion "rig".
    const int n = int(LoadRig(o.rig).cameras.size());
    grid.erase(std::remove_if(grid.begin(), grid.end(),
                              [](const Config& c) {
                                return c.width != 320 || c.cameras != 4 || c.distortion != "none" ||
                                       c.backend != "cpu" || c.spacing != PlaneSpacing::kUniformDepth;
                              }),
               grid.end());
    for (auto& c : grid) c.cameras = n, c.distortion = "rig";
  }
  if (o.headline_only)
    grid.erase(std::remove_if(grid.begin(), grid.end(),
                              [](const Config& c) {
                                return c.width != 320 || c.cameras != 4 || c.distortion != "none" || c.backend != "cpu";
                              }),
               grid.end());
  std::map<std::tuple<int, int, int, bool>, Setting> settings;
  nlohmann::json rows = nlohmann::json::array();
  nlohmann::json refs = nlohmann::json::array();
  size_t done = 0;
  for (const Config& c : grid) {
    const bool distorted = c.distortion == "corrected" || c.distortion == "ignored";
    const auto key = std::make_tuple(c.cameras, c.width, c.height, distorted);
    if (!settings.count(key)) {
      settings.emplace(key, MakeSetting(o, c.cameras, c.width, c.height, distorted));
      const Setting& s = settings.at(key);
      refs.push_back({{"cameras", c.cameras},
                      {"width", c.width},
                      {"height", c.height},
                      {"distorted", distorted},
                      {"exact_reference_s", s.exact_seconds},
                      {"hull_pixels", s.hull_vs_shapes.both + s.hull_vs_shapes.only_got},
                      {"hull_vs_shapes_mm_median", s.hull_vs_shapes.err_mm_median},
                      {"hull_vs_shapes_mm_p95", s.hull_vs_shapes.err_mm_p95},
                      {"hull_without_shape", s.hull_vs_shapes.wrong_inside},
                      {"shape_without_hull", s.hull_vs_shapes.wrong_outside}});
    }
    const Setting& s = settings.at(key);
    const VolumeQuery& q = c.distortion == "ignored" ? *s.query_ignored : *s.query;
    PlaneSweepOptions po;
    po.num_planes = c.planes;
    po.spacing = c.spacing;
    const cv::Rect all(0, 0, c.width, c.height);
    cv::Mat depth;
    std::vector<double> ms;
    for (int rep = 0; rep < std::max(1, o.repeats); ++rep) {
      const auto t0 = Clock::now();
      const std::vector<double> depths = SweepPlaneDepths(q, s.view, po);
      if (c.backend == "gl") {
        depth = gl_sweep->Sweep(q, s.view, depths, all);
        RefineSweepDepth(q, s.view, depths, all, c.refine, &depth, o.threads);
      } else {
        depth = PlaneSweepCpu(q, s.view, depths, all, nullptr, o.threads, c.refine);
      }
      ms.push_back(1e3 * std::chrono::duration<double>(Clock::now() - t0).count());
    }
    const DepthComparison e = CompareDepth(depth, s.exact);
    const DepthComparison es = CompareDepth(depth, s.shapes);
    rows.push_back({{"scene", o.scene},
                    {"placement", o.placement},
                    {"planes", c.planes},
                    {"spacing", SpacingName(c.spacing)},
                    {"width", c.width},
                    {"height", c.height},
                    {"cameras", c.cameras},
                    {"backend", c.backend},
                    {"refine", c.refine},
                    {"distortion", c.distortion},
                    {"threads", c.backend == "gl" ? 0 : o.threads},
                    {"ms", Median(ms)},
                    {"depth_err_mm_median", e.err_mm_median},
                    {"depth_err_mm_p95", e.err_mm_p95},
                    {"depth_err_mm_max", e.err_mm_max},
                    {"wrong_inside", e.wrong_inside},
                    {"wrong_outside", e.wrong_outside},
                    {"shape_err_mm_median", es.err_mm_median},
                    {"shape_err_mm_p95", es.err_mm_p95}});
    if (!o.json)
      std::fprintf(stderr, "\r%zu/%zu configurations", ++done, grid.size());
  }
  if (!o.json) std::fprintf(stderr, "\n");
  // Pareto front of time against p95 depth error among the rows of the headline
  // setting (320x240, 4 cameras, no distortion): no other row is both faster and
  // more accurate.
  for (auto& r : rows) {
    r["pareto"] = false;
    if (r["width"] != 320 || r["cameras"] != 4 || (r["distortion"] != "none" && r["distortion"] != "rig")) continue;
    bool dominated = false;
    for (const auto& x : rows) {
      if (x["width"] != 320 || x["cameras"] != 4 || x["distortion"] != r["distortion"]) continue;
      const double xm = x["ms"], rm = r["ms"], xe = x["depth_err_mm_p95"], re = r["depth_err_mm_p95"];
      if (xm <= rm && xe <= re && (xm < rm || xe < re)) dominated = true;
    }
    r["pareto"] = !dominated;
  }
  // The refinement goal (paper §3.3; docs/benchmarks.md): median < 1 mm, p95 < 5 mm at 320x240 with 4
  // cameras in under 20 ms; the fastest CPU row meeting the error part.
  nlohmann::json goal = nullptr;
  for (const auto& r : rows) {
    if (r["width"] != 320 || r["cameras"] != 4 || (r["distortion"] != "none" && r["distortion"] != "rig") ||
        r["backend"] != "cpu")
      continue;
    if (double(r["depth_err_mm_median"]) < 1.0 && double(r["depth_err_mm_p95"]) < 5.0 &&
        (goal.is_null() || double(r["ms"]) < double(goal["ms"])))
      goal = r;
  }
  nlohmann::json out = {{"scene", o.scene},
                        {"placement", o.placement},
                        {"camera_size", {o.camera_width, o.camera_height}},
                        {"time_s", o.time_s},
                        {"gl_renderer", ctx ? ctx->renderer() : ""},
                        {"references", refs},
                        {"rows", rows},
                        {"goal_row", goal},
                        {"goal_met", !goal.is_null() && double(goal["ms"]) < 20.0}};
  if (!o.tsv.empty()) {
    std::ofstream f(o.tsv);
    f << "# planes\tspacing\twidth\theight\tcameras\tbackend\trefine\tdistortion\tms\tmedian_mm\tp95_mm\twrong_"
         "inside\twrong_outside\tpareto\n";
    for (const auto& r : rows)
      f << r["planes"] << '\t' << std::string(r["spacing"]) << '\t' << r["width"] << '\t' << r["height"] << '\t'
        << r["cameras"] << '\t' << std::string(r["backend"]) << '\t' << r["refine"] << '\t'
        << std::string(r["distortion"]) << '\t' << double(r["ms"]) << '\t' << double(r["depth_err_mm_median"])
        << '\t' << double(r["depth_err_mm_p95"]) << '\t' << double(r["wrong_inside"]) << '\t'
        << double(r["wrong_outside"]) << '\t' << (bool(r["pareto"]) ? 1 : 0) << '\n';
  }
  if (o.json) {
    out["command"] = CommandLine();
    std::cout << out.dump(1) << std::endl;
    return 0;
  }
  std::printf("scene %s, %s cameras %dx%d\n", o.scene.c_str(), o.placement.c_str(), o.camera_width, o.camera_height);
  for (const auto& r : refs)
    std::printf("reference %2d cams %3dx%-3d %-9s: hull vs shapes median %.2f mm p95 %.2f mm (exact hull in %.1f s)\n",
                int(r["cameras"]), int(r["width"]), int(r["height"]), bool(r["distorted"]) ? "distorted" : "",
                double(r["hull_vs_shapes_mm_median"]), double(r["hull_vs_shapes_mm_p95"]),
                double(r["exact_reference_s"]));
  std::printf("%6s %-8s %7s %4s %-4s %6s %-9s %9s %9s %9s %9s %8s %8s %s\n", "planes", "spacing", "view", "cams",
              "be", "refine", "distort", "ms", "med mm", "p95 mm", "max mm", "w.in", "w.out", "pareto");
  for (const auto& r : rows)
    std::printf("%6d %-8s %3dx%-3d %4d %-4s %6d %-9s %9.2f %9.3f %9.3f %9.2f %8.4f %8.4f %s\n", int(r["planes"]),
                std::string(r["spacing"]).c_str(), int(r["width"]), int(r["height"]), int(r["cameras"]),
                std::string(r["backend"]).c_str(), int(r["refine"]), std::string(r["distortion"]).c_str(),
                double(r["ms"]), double(r["depth_err_mm_median"]), double(r["depth_err_mm_p95"]),
                double(r["depth_err_mm_max"]), double(r["wrong_inside"]), double(r["wrong_outside"]),
                bool(r["pareto"]) ? "*" : "");
  return 0;
}

}  // namespace hullpipe

namespace hullpipe {

int RunTextureEval(const TextureEvalOptions& o) {
  nlohmann::json rows = nlohmann::json::array();
  for (const std::string& name : o.scenes) {
    for (int n : o.cameras) {
      SweepEvalOptions so;
      so.scene = name;
      so.threads_reference = o.threads;
      // The same cameras and view as `vh_eval sweep`, with colour images.
      const SyntheticScene scene = NamedScene(name, so.time_s);
      Setting s = MakeSetting(so, n, o.width, o.height, false);
      std::vector<CameraImage> images;
      for (const auto& c : s.true_cams) images.push_back({c, RenderColour(c, scene)});
      Camera eye;
      eye.width = o.width, eye.height = o.height;
      eye.fx = s.view.fx, eye.fy = s.view.fy, eye.cx = s.view.cx, eye.cy = s.view.cy;
      eye.cam_from_world = s.view.world_from_eye.Inverse();
      const cv::Mat truth = RenderColour(eye, scene);
      PlaneSweepOptions po;
      po.num_planes = 128;
      const cv::Rect all(0, 0, o.width, o.height);
      const cv::Mat depth = PlaneSweepCpu(*s.query, s.view, SweepPlaneDepths(*s.query, s.view, po), all, nullptr,
                                          o.threads, 8);
      for (bool vis : {false, true}) {
        const auto t0 = Clock::now();
        std::optional<HullVisibility> hv;
        if (vis) hv = ComputeHullVisibility(*s.query, s.true_cams, 160, po, 8, o.threads);
        const cv::Mat colour = TextureHull(depth, all, s.view, images, {}, hv ? &*hv : nullptr);
        const double ms = 1e3 * std::chrono::duration<double>(Clock::now() - t0).count();
        // Over pixels that are both hull and a true shape: the colour the cameras
        // saw of the true surface against what the hull's texture shows there.
        std::vector<double> err;
        for (int r = 0; r < o.height; ++r)
          for (int c = 0; c < o.width; ++c) {
            if (!std::isfinite(depth.at<float>(r, c)) || !std::isfinite(s.shapes.at<float>(r, c))) continue;
            const cv::Vec3b a = colour.at<cv::Vec3b>(r, c), b = truth.at<cv::Vec3b>(r, c);
            err.push_back((std::abs(a[0] - b[0]) + std::abs(a[1] - b[1]) + std::abs(a[2] - b[2])) / 3.0);
          }
        std::sort(err.begin(), err.end());
        double mean = 0;
        for (double e : err) mean += e;
        mean /= std::max<size_t>(1, err.size());
        const double p95 = err.empty() ? 0 : err[size_t(0.95 * double(err.size() - 1))];
        const double bad = err.empty() ? 0
                                       : double(err.end() - std::upper_bound(err.begin(), err.end(), 30.0)) /
                                             double(err.size());
        rows.push_back({{"scene", name},
                        {"cameras", n},
                        {"width", o.width},
                        {"height", o.height},
                        {"visibility", vis},
                        {"ms", ms},
                        {"pixels", err.size()},
                        {"colour_err_mean", mean},
                        {"colour_err_p95", p95},
                        {"fraction_err_over_30", bad}});
      }
    }
  }
  if (o.json) {
    std::cout << nlohmann::json{{"rows", rows}, {"command", CommandLine()}}.dump(1) << std::endl;
    return 0;
  }
  std::printf("%-8s %4s %-10s %9s %9s %9s %9s\n", "scene", "cams", "visibility", "ms", "err mean", "err p95",
              ">30");
  for (const auto& r : rows)
    std::printf("%-8s %4d %-10s %9.1f %9.2f %9.2f %9.4f\n", std::string(r["scene"]).c_str(), int(r["cameras"]),
                bool(r["visibility"]) ? "yes" : "no", double(r["ms"]), double(r["colour_err_mean"]),
                double(r["colour_err_p95"]), double(r["fraction_err_over_30"]));
  return 0;
}

}  // namespace hullpipe
