#include "vh_eval_reprojection.h"

#include <cstdio>
#include <iostream>
#include <map>
#include <memory>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "hullpipe/evaluation/reprojection.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/reconstruction/volume_query.h"
#include "hullpipe/segmentation/video_rig.h"
#include "hullpipe/util/cli_range.h"
#include "hullpipe/util/logging.h"

namespace hullpipe {

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

void AddReprojectionOptions(CLI::App* rep, ReprojectionEvalOptions& o) {
  auto* rig_opt = rep->add_option("--rig", o.rig, "Rig directory or YAML rig file");
  rep->add_option("--synthetic", o.synthetic, "Instead of a rig: a synthetic figure seen by N dome cameras")
      ->check(CLI::Range(2, 64))
      ->excludes(rig_opt);
  rep->add_option("--width", o.width, "--synthetic: image width")->check(CLI::Range(16, 4096))->capture_default_str();
  rep->add_option("--height", o.height, "--synthetic: image height")
      ->check(CLI::Range(16, 4096))
      ->capture_default_str();
  rep->add_option("--method", o.method, "exact (ray–hull intervals) or march (--step)")
      ->check(CLI::IsMember({"exact", "march"}))
      ->capture_default_str();
  rep->add_option("--threads", o.threads, "Threads")->check(CLI::Range(1, 256))->capture_default_str();
  rep->add_option("--frame", o.frame, "Frame index (0-based)")->capture_default_str();
  rep->add_option("--step", o.step, "--method march: ray-marching step, metres")
      ->check(hullpipe::FiniteRange(1e-4, 1.0))
      ->capture_default_str();
  rep->add_flag("--json", o.json, "Print one JSON object");
  rep->add_flag("--all-frames", o.all_frames, "Evaluate every frame; report mean and worst per camera");
  rep->add_option("--save-worst", o.save_worst, "With --all-frames: PNG of the worst frame's reprojections");
}

int RunReprojectionEval(const ReprojectionEvalOptions& o) {
  ReprojectOptions ro;
  ro.exact = o.method == "exact";
  ro.step = o.step;
  ro.threads = o.threads;
  if (o.synthetic > 0) {
    const SyntheticScene scene = NamedScene("figure", 0.5);
    const auto cams = DomeCameras(o.synthetic, 3.0, Eigen::Vector3d(0, 0, -1.0), o.width, o.height, 1.0);
    std::vector<CameraMap> views;
    for (const auto& c : cams) views.push_back({c, RenderExactMap(c, scene)});
    Aabb ws;
    ws.min = Eigen::Vector3d(-2, -2, -2.5);
    ws.max = Eigen::Vector3d(2, 2, 0.05);
    const double t0 = MonotonicSeconds();
    const auto res = EvaluateViews(views, ws, ro);
    const double seconds = MonotonicSeconds() - t0;
    nlohmann::json j = {{"synthetic_cameras", o.synthetic}, {"width", o.width}, {"height", o.height},
                        {"method", o.method}, {"threads", ro.threads}, {"seconds", seconds}};
    char header[160];
    std::snprintf(header, sizeof header, "%d synthetic cameras %dx%d, %s: %.2f s", o.synthetic, o.width, o.height,
                  o.method.c_str(), seconds);
    ReportFrame(res, header, o.json, &j);
    j["command"] = CommandLine();
    if (o.json) std::cout << j.dump(2) << std::endl;
    return 0;
  }
  if (o.rig.empty()) throw std::invalid_argument("give --rig DIR or --synthetic N");
  auto src = OpenVideoRig(o.rig, {});
  RigFrame f;
  // How it was made: the method, and the march's step only for the march (an
  // exact run has none).
  nlohmann::json j = {{"rig", o.rig}, {"method", o.method}, {"threads", ro.threads}};
  j["step_m"] = ro.exact ? nlohmann::json(nullptr) : nlohmann::json(ro.step);
  if (!o.all_frames) {
    for (int k = 0; k <= o.frame; ++k)
      if (!src->Next(&f)) throw std::runtime_error("the rig has fewer than " + std::to_string(o.frame + 1) + " frames");
    for (size_t i = 0; i < f.maps.size(); ++i)
      if (f.maps[i].empty()) throw std::runtime_error("frame " + std::to_string(o.frame) + " unreadable in a camera");
    const double t0 = MonotonicSeconds();
    const auto res = EvaluateFrame(*src, f, ro);
    const double seconds = MonotonicSeconds() - t0;
    j["frame"] = o.frame;
    j["seconds"] = seconds;
    char header[96];
    std::snprintf(header, sizeof header, "frame %d (%s, %.2f s)", o.frame, o.method.c_str(), seconds);
    ReportFrame(res, header, o.json, &j);
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
        if (!o.save_worst.empty()) {
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
          cv::imwrite(o.save_worst, row);
        }
      }
      if (!o.json) std::fprintf(stderr, "\rframe %d", k);
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
    if (!o.json) {
      std::printf("\n%d frames\n%-8s %14s %14s %14s %14s\n", k, "camera", "all mean", "all worst", "loo mean",
                  "loo worst");
      for (const auto& [id, a] : acc)
        std::printf("%-8d %14.3f %14.3f %14.3f %14.3f\n", id, a.sum_all / std::max(1, evaluated), a.min_all,
                    a.sum_loo / std::max(1, evaluated), a.min_loo);
    }
  }
  j["command"] = CommandLine();
  if (o.json) std::cout << j.dump(2) << std::endl;
  return 0;
}

}  // namespace hullpipe
