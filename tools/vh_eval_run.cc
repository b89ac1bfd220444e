#include "vh_eval_run.h"

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <memory>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/evaluation/run_check.h"
#include "hullpipe/reconstruction/volume_query.h"
#include "hullpipe/segmentation/video_rig.h"
#include "hullpipe/util/logging.h"

namespace hullpipe {

void AddRunEvalOptions(CLI::App* sub, RunEvalOptions& o) {
  sub->add_option("--rig", o.rig, "The rig the run read: directory or YAML rig file")->required();
  sub->add_option("--run", o.run, "The run's --out directory (render_node --save-depth)")->required();
  sub->add_option("--max-frames", o.max_frames, "At most this many saved frames (0: all)")
      ->check(CLI::Range(0, 100000000))
      ->capture_default_str();
  sub->add_option("--planes", o.planes, "The recon nodes' --planes")->check(CLI::Range(2, 4096))->capture_default_str();
  sub->add_option("--refine", o.refine, "The recon nodes' --refine")->check(CLI::Range(0, 30))->capture_default_str();
  sub->add_option("--out-of-view", o.out_of_view, "The recon nodes' --out-of-view")
      ->check(CLI::IsMember({"unknown", "outside"}))
      ->capture_default_str();
  sub->add_option("--exact-stride", o.exact_stride, "Exact intervals at every N-th pixel in x and y")
      ->check(CLI::Range(1, 4096))
      ->capture_default_str();
  sub->add_option("--threads", o.threads, "Threads")->check(CLI::Range(1, 256))->capture_default_str();
  sub->add_flag("--json", o.json, "Print one JSON object");
  sub->add_option("--eye", o.eye,
                  "A stereo run's eye (render_node --stereo): left (views.csv) or right (views_right.csv)")
      ->check(CLI::IsMember({"left", "right"}))
      ->capture_default_str();
}

int RunRunEval(const RunEvalOptions& o) {
  const bool right = o.eye == "right";
  const std::string views_csv = o.run + (right ? "/views_right.csv" : "/views.csv");
  const auto views = ReadRunViews(views_csv);
  if (views.empty()) throw std::runtime_error(views_csv + ": no frame saved");
  RunCheckOptions co;
  co.sweep.num_planes = o.planes;
  co.refine = o.refine;
  co.exact_stride = o.exact_stride;
  co.threads = o.threads;
  co.Check();
  VolumeQueryOptions qo;
  qo.out_of_view = o.out_of_view == "outside" ? OutOfView::kOutside : OutOfView::kUnknown;
  auto src = OpenVideoRig(o.rig, {});
  nlohmann::json j = {{"rig", o.rig},          {"run", o.run},       {"eye", o.eye},     {"planes", o.planes},
                      {"refine", o.refine},    {"out_of_view", o.out_of_view},
                      {"exact_stride", o.exact_stride},              {"frames", nlohmann::json::array()}};
  if (!o.json)
    std::printf("%-7s %9s %9s %9s %9s %11s %11s %13s %13s %8s\n", "frame", "pixels", "hull px", "= sweep",
                "exact px", "only run", "only exact", "err med mm", "err p95 mm", "s");
  RigFrame f;
  uint64_t at = 0;  // frames read from the rig
  int checked = 0, failed = 0;
  int64_t pixels = 0, equal = 0, only_run = 0, only_exact = 0, both = 0;
  std::vector<double> medians;
  for (const RunView& rv : views) {
    if (o.max_frames > 0 && checked + failed >= o.max_frames) break;
    if (rv.frame_seq <= at)
      throw std::runtime_error(views_csv + ": frame " + std::to_string(rv.frame_seq) + " is not after frame " +
                               std::to_string(at));
    while (at < rv.frame_seq) {
      if (!src->Next(&f))
        throw std::runtime_error(o.rig + ": has " + std::to_string(at) + " frames; the run composited frame " +
                                 std::to_string(rv.frame_seq) + " (is it the rig the run read?)");
      ++at;
    }
    const std::string depth_path = RunDepthPath(o.run, rv.frame_seq, right);
    const cv::Mat depth = cv::imread(depth_path, cv::IMREAD_UNCHANGED);
    std::vector<CameraMap> maps;
    for (size_t i = 0; i < src->cameras().size(); ++i)
      if (!f.maps[i].empty()) maps.push_back({src->cameras()[i], f.maps[i]});
    std::string problem;
    if (depth.empty()) problem = depth_path + ": missing or unreadable";
    else if (depth.type() != CV_32FC1 || depth.cols != rv.view.width || depth.rows != rv.view.height)
      problem = depth_path + ": not a float depth of the view's size";
    else if (maps.size() != src->cameras().size())
      problem = o.rig + ": frame " + std::to_string(rv.frame_seq) + " unreadable in a camera";
    if (!problem.empty()) {
      spdlog::error("{}", problem);
      j["frames"].push_back({{"frame_seq", rv.frame_seq}, {"error", problem}});
      ++failed;
      continue;
    }
    const VolumeQuery q(maps, src->workspace(), qo);
    const RunFrameCheck c = CheckRunFrame(q, rv.view, depth, co);
    ++checked;
    pixels += c.pixels, equal += c.equal_to_sweep;
    only_run += c.exact.only_got, only_exact += c.exact.only_ref, both += c.exact.both;
    medians.push_back(c.exact.err_mm_median);
    j["frames"].push_back({{"frame_seq", rv.frame_seq},
                           {"pixels", c.pixels},
                           {"hull_pixels", c.hull_pixels},
                           {"equal_to_sweep", c.equal_to_sweep},
                           {"exact_pixels", c.exact_pixels},
                           {"exact_both", c.exact.both},
                           {"only_run", c.exact.only_got},
                           {"only_exact", c.exact.only_ref},
                           {"err_mm_median", c.exact.err_mm_median},
                           {"err_mm_p95", c.exact.err_mm_p95},
                           {"seconds", c.seconds}});
    if (!o.json)
      std::printf("%-7llu %9lld %9lld %9lld %9lld %11lld %11lld %13.3f %13.2f %8.1f\n",
                  (unsigned long long)rv.frame_seq, (long long)c.pixels, (long long)c.hull_pixels,
                  (long long)c.equal_to_sweep, (long long)c.exact_pixels, (long long)c.exact.only_got,
                  (long long)c.exact.only_ref, c.exact.err_mm_median, c.exact.err_mm_p95, c.seconds);
  }
  std::sort(medians.begin(), medians.end());
  j["frames_checked"] = checked;
  j["frames_failed"] = failed;
  j["pixels"] = pixels;
  j["equal_to_sweep"] = equal;
  j["exact_both"] = both;
  j["only_run"] = only_run;
  j["only_exact"] = only_exact;
  j["worst_frame_err_mm_median"] = medians.empty() ? 0.0 : medians.back();
  j["command"] = CommandLine();
  if (o.json) {
    std::cout << j.dump(2) << std::endl;
  } else {
    std::printf("%d frames checked (%d failed): %lld of %lld pixels equal to the direct sweep; against the exact "
                "intervals %lld hull pixels in both, %lld only in the run, %lld only exact; worst frame's median "
                "error %.3f mm\n",
                checked, failed, (long long)equal, (long long)pixels, (long long)both, (long long)only_run,
                (long long)only_exact, medians.empty() ? 0.0 : medians.back());
  }
  return failed > 0 || checked == 0 ? 1 : 0;
}

}  // namespace hullpipe
