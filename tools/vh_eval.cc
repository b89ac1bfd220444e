// vh_eval: evaluation of hullpipe's visual hulls.
//   vh_eval collision [--json] [--smoke] [--tsv FILE]
// collision detection and the paper's §4.2 response (exact and paper methods)
// against exact ground truth, per backend and viewport size (vh_eval_collision.h).
//   vh_eval sweep [--json] [--full] [--tsv FILE]
// runs the plane sweep on synthetic scenes with exact maps and reports, per
// configuration, time per frame and depth error against the exact hull (see
// vh_eval_sweep.h).
//   vh_eval reprojection --rig DIR --frame K [--json] [--all-frames] [--method exact|march --step M]
//   vh_eval reprojection --synthetic N [--width W --height H]
// builds the hull of frame K by volume querying and prints, per camera, the IoU
// between the hull's reprojection and that camera's object-pixel map (iou_all),
// and the same with the hull built from the other cameras only
// (iou_leave_one_out), and the seconds the frame took. The reprojection is exact
// (ray–hull intervals, ExactReprojector) unless --method march. With
// --all-frames: mean and worst over every frame. --synthetic N: one frame of a
// synthetic figure seen by N dome cameras with exact maps (the timing case of a
// 20-camera rig).
//   vh_eval held-out --rig DIR [--stride S --first F --max-frames N] [--images DIR --image-frame K]
// holds out each camera in turn, renders the textured hull of the others from
// its pose and compares with its real image inside its map (PSNR, SSIM, IoU), for
// each texturing variant (vh_eval_held_out.h).
//   vh_eval segmentation --rig DIR [--stride S ...]
// the same measure for each segmentation setting and the adaptive background.
#include <cstdio>
#include <memory>
#include <iostream>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/evaluation/reprojection.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/util/cli_range.h"
#include "hullpipe/evaluation/synthetic_source.h"
#include "hullpipe/segmentation/video_rig.h"
#include "vh_eval_collision.h"
#include "vh_eval_held_out.h"
#include "vh_eval_sweep.h"

using namespace hullpipe;

namespace {

struct CameraIoU {
  int id;
  double all, loo;
};

// How `vh_eval reprojection` reprojects: exact (ExactReprojector) or marched
// at `step` metres; threads for either.
struct ReprojectOptions {
  bool exact = true;
  double step = 0.005;
  int threads = 2;
};

std::vector<CameraIoU> EvaluateViews(const std::vector<CameraMap>& views, const Aabb& workspace,
                                     const ReprojectOptions& o) {
  const VolumeQuery all(views, workspace);
  std::vector<CameraIoU> out;
  if (o.exact) {
    const ExactReprojector reprojector(all, o.threads);
    for (size_t i = 0; i < views.size(); ++i) {
      const Reprojection r = reprojector.Reproject(i, o.threads);
      out.push_back({views[i].camera.id, MaskIoU(r.all, views[i].map), MaskIoU(r.leave_one_out, views[i].map)});
    }
    return out;
  }
  for (size_t i = 0; i < views.size(); ++i) {
    std::vector<int> others;
    for (size_t j = 0; j < views.size(); ++j)
      if (j != i) others.push_back(int(j));
    const VolumeQuery loo = all.Subset(others);
    const Camera& cam = views[i].camera;
    out.push_back({cam.id, MaskIoU(ReprojectHull(all, cam, o.step, o.threads), views[i].map),
                   MaskIoU(ReprojectHull(loo, cam, o.step, o.threads), views[i].map)});
  }
  return out;
}

std::vector<CameraIoU> EvaluateFrame(const RigSource& src, const RigFrame& f, const ReprojectOptions& o) {
  std::vector<CameraMap> views;
  for (size_t i = 0; i < src.cameras().size(); ++i) views.push_back({src.cameras()[i], f.maps[i]});
  return EvaluateViews(views, src.workspace(), o);
}

// One evaluated frame: its per-camera rows into j["cameras"], and (unless
// json) the header line and the table on stdout.
void ReportFrame(const std::vector<CameraIoU>& res, const std::string& header, bool json, nlohmann::json* j) {
  for (const auto& r : res) (*j)["cameras"].push_back({{"id", r.id}, {"iou_all", r.all}, {"iou_leave_one_out", r.loo}});
  if (json) return;
  std::printf("%s\n%-8s %10s %20s\n", header.c_str(), "camera", "iou_all", "iou_leave_one_out");
  for (const auto& r : res) std::printf("%-8d %10.3f %20.3f\n", r.id, r.all, r.loo);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"vh_eval: accuracy of hullpipe's visual hulls"};
  app.require_subcommand(1);
  SweepEvalOptions sw;
  auto* sweep = app.add_subcommand("sweep", "Plane sweep speed against error, against the exact hull (synthetic)");
  sweep->add_flag("--json", sw.json, "Print one JSON object with a row per configuration");
  sweep->add_option("--scene", sw.scene, "Synthetic scene: sphere|box|torus|hand|figure|mixed")->capture_default_str();
  sweep->add_option("--placement", sw.placement, "Camera placement: dome|ring|rig (the cameras of --rig)")
      ->check(CLI::IsMember({"dome", "ring", "rig"}))
      ->capture_default_str();
  sweep->add_option("--repeats", sw.repeats, "Timed runs per configuration (median)")->capture_default_str();
  sweep->add_option("--threads", sw.threads, "CPU sweep threads")->capture_default_str();
  sweep->add_option("--time", sw.time_s, "Scene time, seconds")->capture_default_str();
  sweep->add_flag("!--no-gl", sw.gl, "Leave out the GL rows");
  sweep->add_flag("--full", sw.full, "Every combination of planes, spacing, view, cameras, backend, refine");
  sweep->add_option("--rig", sw.rig, "Rig directory or YAML file, for --placement rig");
  sweep->add_flag("--smoke", sw.smoke, "A few small rows in seconds (for tests)");
  sweep->add_flag("--headline", sw.headline_only, "Only the CPU rows at 320x240 with 4 cameras");
  sweep->add_option("--tsv", sw.tsv, "Also write the rows as TSV (for gnuplot)");
  TextureEvalOptions tx;
  CollisionEvalOptions co;
  auto* collision = app.add_subcommand("collision", "Collision detection and response against exact ground truth");
  collision->add_flag("--json", co.json, "Print one JSON object with a row per method, backend and viewport");
  collision->add_option("--scenes", co.scenes, "Synthetic scenes (the real objects)")->capture_default_str();
  collision->add_option("--cases", co.cases_per_scene, "Virtual boxes per scene")->capture_default_str();
  collision->add_option("--cameras", co.cameras, "Dome cameras")->capture_default_str();
  collision->add_option("--repeats", co.repeats, "Timed runs of each detection (median)")->capture_default_str();
  collision->add_option("--reference-spacing", co.reference_spacing, "Exact region line spacing, metres")
      ->capture_default_str();
  collision->add_option("--seed", co.seed, "Case generator seed")->capture_default_str();
  collision->add_flag("!--no-gl", co.gl, "Leave out the GL rows");
  collision->add_option("--normal-fit-radius", co.normal_fit_radius_px,
                        "Exact method: radius (px) of border pixels fitted for N_hull (default 3)");
  collision->add_flag("--smoke", co.smoke, "One scene, three cases, CPU only (for tests)");
  collision->add_option("--tsv", co.tsv, "Also write the rows as TSV (for gnuplot)");
  auto* texture = app.add_subcommand("texture", "Colour error of the textured hull, with and without visibility");
  texture->add_flag("--json", tx.json, "Print one JSON object");
  texture->add_option("--scenes", tx.scenes, "Synthetic scenes")->capture_default_str();
  texture->add_option("--cameras", tx.cameras, "Camera counts")->capture_default_str();
  texture->add_option("--threads", tx.threads, "Threads")->capture_default_str();
  auto* rep = app.add_subcommand("reprojection", "Per-camera IoU of the hull's reprojection with the maps");
  std::string rig;
  int frame = 200;
  bool json = false, all_frames = false;
  ReprojectOptions ro;
  std::string save_worst;
  auto* rig_opt = rep->add_option("--rig", rig, "Rig directory or YAML rig file");
  int synthetic = 0, syn_w = 1024, syn_h = 768;
  std::string method = "exact";
  rep->add_option("--synthetic", synthetic, "Instead of a rig: a synthetic figure seen by N dome cameras")
      ->check(CLI::Range(2, 64))
      ->excludes(rig_opt);
  rep->add_option("--width", syn_w, "--synthetic: image width")->check(CLI::Range(16, 4096))->capture_default_str();
  rep->add_option("--height", syn_h, "--synthetic: image height")->check(CLI::Range(16, 4096))->capture_default_str();
  rep->add_option("--method", method, "exact (ray–hull intervals) or march (--step)")
      ->check(CLI::IsMember({"exact", "march"}))
      ->capture_default_str();
  rep->add_option("--threads", ro.threads, "Threads")->check(CLI::Range(1, 256))->capture_default_str();
  rep->add_option("--frame", frame, "Frame index (0-based)")->capture_default_str();
  rep->add_option("--step", ro.step, "--method march: ray-marching step, metres")
      ->check(hullpipe::FiniteRange(1e-4, 1.0))
      ->capture_default_str();
  rep->add_flag("--json", json, "Print one JSON object");
  rep->add_flag("--all-frames", all_frames, "Evaluate every frame; report mean and worst per camera");
  rep->add_option("--save-worst", save_worst, "With --all-frames: PNG of the worst frame's reprojections");
  HeldOutEvalOptions ho;
  auto* held = app.add_subcommand("held-out", "Rendering error from each held-out camera's pose, per texturing variant");
  auto* seg = app.add_subcommand("segmentation", "Held-out rendering error per segmentation setting");
  for (auto* sub : {held, seg}) {
    sub->add_option("--rig", ho.rig, "Rig directory or YAML rig file")->required();
    sub->add_option("--stride", ho.stride, "Evaluate every S-th frame")->check(CLI::Range(1, 1000000))->capture_default_str();
    sub->add_option("--first", ho.first, "First frame evaluated (0-based)")->check(CLI::Range(0, 100000000))->capture_default_str();
    sub->add_option("--max-frames", ho.max_frames, "At most this many frames (0: to the end)")
        ->check(CLI::Range(0, 100000000))
        ->capture_default_str();
    sub->add_option("--threads", ho.threads, "Threads")->check(CLI::Range(1, 256))->capture_default_str();
    sub->add_flag("--json", ho.json, "Print one JSON object");
  }
  auto* images = held->add_option("--images", ho.images_dir,
                                   "Write figures (JPEG) of the --image-frame frames into this directory")
                     ->check(CLI::ExistingDirectory);
  held->add_option("--image-frame", ho.image_frames, "Frames to draw (with --images)")->needs(images);
  images->needs(held->get_option("--image-frame"));
  CLI11_PARSE(app, argc, argv);
  spdlog::set_level(spdlog::level::warn);
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  if (collision->parsed()) {
    try {
      return RunCollisionEval(co);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "vh_eval: %s\n", e.what());
      return 1;
    }
  }
  if (held->parsed() || seg->parsed()) {
    try {
      return held->parsed() ? RunHeldOutEval(ho) : RunSegmentationEval(ho);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "vh_eval: %s\n", e.what());
      return 1;
    }
  }
  if (sweep->parsed() || texture->parsed()) {
    try {
      if (sw.smoke) sw.camera_width = 320, sw.camera_height = 240, sw.repeats = 1;
      return sweep->parsed() ? RunSweepEval(sw) : RunTextureEval(tx);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "vh_eval: %s\n", e.what());
      return 1;
    }
  }
  ro.exact = method == "exact";
  try {
    if (synthetic > 0) {
      const SyntheticScene scene = NamedScene("figure", 0.5);
      const auto cams = DomeCameras(synthetic, 3.0, Eigen::Vector3d(0, 0, -1.0), syn_w, syn_h, 1.0);
      std::vector<CameraMap> views;
      for (const auto& c : cams) views.push_back({c, RenderExactMap(c, scene)});
      Aabb ws;
      ws.min = Eigen::Vector3d(-2, -2, -2.5);
      ws.max = Eigen::Vector3d(2, 2, 0.05);
      const double t0 = MonotonicSeconds();
      const auto res = EvaluateViews(views, ws, ro);
      const double seconds = MonotonicSeconds() - t0;
      nlohmann::json j = {{"synthetic_cameras", synthetic}, {"width", syn_w}, {"height", syn_h},
                          {"method", method}, {"threads", ro.threads}, {"seconds", seconds}};
      char header[160];
      std::snprintf(header, sizeof header, "%d synthetic cameras %dx%d, %s: %.2f s", synthetic, syn_w, syn_h,
                    method.c_str(), seconds);
      ReportFrame(res, header, json, &j);
      if (json) std::cout << j.dump(2) << std::endl;
      return 0;
    }
    if (rig.empty()) throw std::invalid_argument("give --rig DIR or --synthetic N");
    auto src = OpenVideoRig(rig, {});
    RigFrame f;
    nlohmann::json j;
    if (!all_frames) {
      for (int k = 0; k <= frame; ++k)
        if (!src->Next(&f)) throw std::runtime_error("the rig has fewer than " + std::to_string(frame + 1) + " frames");
      for (size_t i = 0; i < f.maps.size(); ++i)
        if (f.maps[i].empty()) throw std::runtime_error("frame " + std::to_string(frame) + " unreadable in a camera");
      const double t0 = MonotonicSeconds();
      const auto res = EvaluateFrame(*src, f, ro);
      const double seconds = MonotonicSeconds() - t0;
      j["frame"] = frame;
      j["step_m"] = ro.step;
      j["seconds"] = seconds;
      char header[96];
      std::snprintf(header, sizeof header, "frame %d (%s, %.2f s)", frame, method.c_str(), seconds);
      ReportFrame(res, header, json, &j);
    } else {
      struct Acc {
        double sum_all = 0, sum_loo = 0, min_all = 1, min_loo = 1;
        int worst_frame = -1;
      };
      std::map<int, Acc> acc;
      int k = 0, evaluated = 0, worst_frame = -1;
      double worst = 2;
      for (; src->Next(&f); ++k) {
        bool ok = true;
        for (const auto& m : f.maps) ok &= !m.empty();
        if (!ok) continue;
        ++evaluated;
        const auto res = EvaluateFrame(*src, f, ro);
        double frame_min = 2;
        for (const auto& r : res) {
          Acc& a = acc[r.id];
          a.sum_all += r.all, a.sum_loo += r.loo;
          a.min_all = std::min(a.min_all, r.all);
          if (r.loo < a.min_loo) a.min_loo = r.loo, a.worst_frame = k;
          frame_min = std::min(frame_min, r.loo);
        }
        if (frame_min < worst) {
          worst = frame_min;
          worst_frame = k;
          if (!save_worst.empty()) {
            std::vector<CameraMap> views;
            for (size_t i = 0; i < src->cameras().size(); ++i) views.push_back({src->cameras()[i], f.maps[i]});
            const VolumeQuery all(views, src->workspace());
            std::vector<cv::Mat> tiles;
            std::unique_ptr<ExactReprojector> reprojector;
            if (ro.exact) reprojector = std::make_unique<ExactReprojector>(all, ro.threads);
            for (size_t i = 0; i < views.size(); ++i) {
              std::vector<int> others;
              for (size_t jx = 0; jx < views.size(); ++jx)
                if (jx != i) others.push_back(int(jx));
              const cv::Mat rep_loo = ro.exact ? reprojector->Reproject(i, ro.threads).leave_one_out
                                               : ReprojectHull(all.Subset(others), views[i].camera, ro.step, ro.threads);
              std::vector<cv::Mat> ch = {rep_loo, views[i].map, views[i].map & rep_loo};
              cv::Mat vis;
              cv::merge(ch, vis);  // blue: hull only, green: map only, white/cyan: both
              tiles.push_back(vis);
            }
            cv::Mat row;
            cv::hconcat(tiles, row);
            cv::imwrite(save_worst, row);
          }
        }
        if (!json) std::fprintf(stderr, "\rframe %d", k);
      }
      j["frames"] = k;
      j["frames_evaluated"] = evaluated;
      j["worst_frame"] = worst_frame;
      for (const auto& [id, a] : acc) {
        const double n = double(std::max(1, evaluated));
        j["cameras"].push_back({{"id", id},
                                {"iou_all_mean", a.sum_all / n},
                                {"iou_all_worst", a.min_all},
                                {"iou_leave_one_out_mean", a.sum_loo / n},
                                {"iou_leave_one_out_worst", a.min_loo},
                                {"worst_frame", a.worst_frame}});
      }
      if (!json) {
        std::printf("\n%d frames\n%-8s %14s %14s %14s %14s\n", k, "camera", "all mean", "all worst", "loo mean",
                    "loo worst");
        for (const auto& [id, a] : acc)
          std::printf("%-8d %14.3f %14.3f %14.3f %14.3f\n", id, a.sum_all / std::max(1, evaluated), a.min_all,
                      a.sum_loo / std::max(1, evaluated), a.min_loo);
      }
    }
    if (json) std::cout << j.dump(2) << std::endl;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vh_eval: %s\n", e.what());
    return 1;
  }
  return 0;
}
