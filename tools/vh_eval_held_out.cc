#include "vh_eval_held_out.h"

#include <algorithm>
#include <cstdio>
#include <functional>
#include <iostream>
#include <map>
#include <stdexcept>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "hullpipe/evaluation/held_out_rendering.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/evaluation/synthetic_source.h"
#include "hullpipe/geometry/calibration.h"
#include "hullpipe/segmentation/video_rig.h"
#include "hullpipe/util/logging.h"

namespace hullpipe {
namespace {

struct Variant {
  std::string name;
  HeldOutOptions options;
};

struct Sample {
  int frame = 0, camera = 0;
  double psnr = 0, ssim = 0, iou = 0, seconds = 0, psnr_covered = 0, ssim_covered = 0;
  double psnr_black = 0;  // the anchor: a black rendering against the same pixels
};

// The recon node's sweep (50 planes fitted to the hull box, 6 refinements) and
// the texturing variants; "blend2+vis" is recon_node's default.
std::vector<Variant> TexturingVariants(int threads) {
  std::vector<Variant> out;
  for (int cams : {1, 2, 3})
    for (int vis : {0, 80}) {
      Variant v;
      v.name = (cams == 1 ? std::string("nearest") : "blend" + std::to_string(cams)) + (vis ? "+vis" : "");
      v.options.texture.max_cameras = cams;
      v.options.visibility_width = vis;
      v.options.threads = threads;
      out.push_back(v);
    }
  return out;
}

// Reads `rig` with `rig_options` and holds out every camera of each selected
// frame under each variant; on_frame sees the frame's results ([variant][camera]).
std::vector<std::vector<Sample>> Evaluate(
    const HeldOutEvalOptions& o, const VideoRigOptions& rig_options, const std::vector<Variant>& variants,
    const std::function<void(int, const std::vector<std::vector<HeldOutResult>>&)>& on_frame = nullptr) {
  if (o.stride < 1 || o.first < 0 || o.max_frames < 0 || o.threads < 1)
    throw std::invalid_argument("--stride and --threads must be >= 1, --first and --max-frames >= 0");
  auto src = OpenVideoRig(o.rig, rig_options);
  if (src->cameras().size() < 3) throw std::invalid_argument(o.rig + ": a held-out camera needs a rig of >= 3 cameras");
  std::vector<std::vector<Sample>> samples(variants.size());
  RigFrame f;
  int evaluated = 0;
  for (int k = 0; src->Next(&f); ++k) {
    if (k < o.first || (k - o.first) % o.stride != 0) continue;
    if (o.max_frames > 0 && evaluated >= o.max_frames) break;
    bool ok = true;
    for (size_t i = 0; i < f.maps.size(); ++i) ok &= !f.maps[i].empty() && !f.images[i].empty();
    if (!ok) {
      std::fprintf(stderr, "vh_eval: frame %d incomplete in a camera; skipped\n", k);
      continue;
    }
    ++evaluated;
    std::vector<CameraMap> views;
    for (size_t i = 0; i < src->cameras().size(); ++i) views.push_back({src->cameras()[i], f.maps[i]});
    std::vector<std::vector<HeldOutResult>> results(variants.size());
    for (size_t v = 0; v < variants.size(); ++v)
      for (size_t i = 0; i < views.size(); ++i) {
        const double t0 = MonotonicSeconds();
        HeldOutResult r = RenderHeldOut(views, f.images, src->workspace(), i, variants[v].options);
        samples[v].push_back({k, views[i].camera.id, r.error.psnr_db, r.error.ssim, r.iou, MonotonicSeconds() - t0,
                              r.error_covered.psnr_db, r.error_covered.ssim,
                              MaskedImageError(r.truth.image, cv::Mat::zeros(r.truth.image.size(), CV_8UC3),
                                               r.truth.map)
                                  .psnr_db});
        results[v].push_back(std::move(r));
      }
    if (on_frame) on_frame(k, results);
    if (!o.json) std::fprintf(stderr, "\rframe %d", k);
  }
  if (!o.json) std::fprintf(stderr, "\n");
  if (evaluated == 0) throw std::runtime_error(o.rig + ": no frame evaluated (--first beyond the end?)");
  return samples;
}

struct Summary {
  double psnr = 0, ssim = 0, iou = 0, seconds = 0, psnr_worst = 1e9, iou_worst = 1;
  double psnr_covered = 0, ssim_covered = 0, psnr_black = 0;
  int n = 0;
};

Summary Summarise(const std::vector<Sample>& s, int camera = -1) {
  Summary out;
  for (const auto& x : s) {
    if (camera >= 0 && x.camera != camera) continue;
    out.psnr += x.psnr, out.ssim += x.ssim, out.iou += x.iou, out.seconds += x.seconds;
    out.psnr_covered += x.psnr_covered, out.ssim_covered += x.ssim_covered, out.psnr_black += x.psnr_black;
    out.psnr_worst = std::min(out.psnr_worst, x.psnr);
    out.iou_worst = std::min(out.iou_worst, x.iou);
    ++out.n;
  }
  if (out.n) {
    out.psnr /= out.n, out.ssim /= out.n, out.iou /= out.n, out.seconds /= out.n;
    out.psnr_covered /= out.n, out.ssim_covered /= out.n, out.psnr_black /= out.n;
  }
  return out;
}

nlohmann::json SummaryJson(const Summary& s) {
  return {{"psnr_db_mean", s.psnr},
          {"ssim_mean", s.ssim},
          {"iou_mean", s.iou},
          {"psnr_db_worst", s.psnr_worst},
          {"iou_worst", s.iou_worst},
          {"psnr_db_covered_mean", s.psnr_covered},
          {"ssim_covered_mean", s.ssim_covered},
          {"psnr_db_black_mean", s.psnr_black},
          {"seconds_mean", s.seconds},
          {"samples", s.n}};
}

// A row of the figure: the held-out camera's real image inside its map, then
// each variant's rendering, cropped to the object (map or hull) with a margin
// and scaled to `height` pixels.
// starts: each tile's left edge in the row.
cv::Mat FigureRow(const std::vector<std::vector<HeldOutResult>>& results, size_t camera, int height,
                  std::vector<int>* starts) {
  const HeldOutResult& first = results[0][camera];
  cv::Rect box = cv::boundingRect(first.truth.map);
  for (const auto& v : results) box |= cv::boundingRect(v[camera].hull);
  const int margin = 8;
  box = cv::Rect(box.x - margin, box.y - margin, box.width + 2 * margin, box.height + 2 * margin) &
        cv::Rect(0, 0, first.truth.map.cols, first.truth.map.rows);
  if (box.area() == 0) box = cv::Rect(0, 0, first.truth.map.cols, first.truth.map.rows);
  cv::Mat truth(first.truth.image.size(), CV_8UC3, cv::Scalar(40, 40, 40));
  first.truth.image.copyTo(truth, first.truth.map);
  std::vector<cv::Mat> tiles = {truth(box)};
  for (const auto& v : results) tiles.push_back(v[camera].rendered(box));
  const double scale = double(height) / box.height;
  starts->clear();
  int x = 0;
  for (auto& t : tiles) {
    starts->push_back(x);
    cv::Mat s;
    cv::resize(t, s, cv::Size(std::max(1, int(t.cols * scale + 0.5)), height), 0, 0, cv::INTER_AREA);
    cv::copyMakeBorder(s, t, 0, 0, 0, 2, cv::BORDER_CONSTANT, cv::Scalar(255, 255, 255));
    x += t.cols;
  }
  cv::Mat row;
  cv::hconcat(tiles, row);
  return row;
}

void WriteFigure(const std::string& path, const std::vector<std::vector<HeldOutResult>>& results,
                 const std::vector<Variant>& variants) {
  std::vector<cv::Mat> rows;
  int width = 0;
  std::vector<int> starts, first_starts;
  for (size_t c = 0; c < results[0].size(); ++c) {
    rows.push_back(FigureRow(results, c, 160, &starts));
    if (c == 0) first_starts = starts;
    width = std::max(width, rows.back().cols);
  }
  for (auto& r : rows)
    cv::copyMakeBorder(r, r, 0, 2, 0, width - r.cols, cv::BORDER_CONSTANT, cv::Scalar(255, 255, 255));
  cv::Mat header(22, width, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::putText(header, "real", {4, 16}, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0));
  for (size_t v = 0; v < variants.size() && v + 1 < first_starts.size(); ++v)
    cv::putText(header, variants[v].name, {4 + first_starts[v + 1], 16}, cv::FONT_HERSHEY_SIMPLEX, 0.4,
                cv::Scalar(0, 0, 0));
  rows.insert(rows.begin(), header);
  cv::Mat fig;
  cv::vconcat(rows, fig);
  if (!cv::imwrite(path, fig, {cv::IMWRITE_JPEG_QUALITY, 88})) throw std::runtime_error("cannot write " + path);
}

}  // namespace

int RunHeldOutEval(const HeldOutEvalOptions& o) {
  const auto variants = TexturingVariants(o.threads);
  auto not_evaluated = [&](int f) {
    return std::invalid_argument(
        "--image-frame " + std::to_string(f) +
        ": not an evaluated frame (frames --first + k * --stride, within --max-frames and the video)");
  };
  for (int f : o.image_frames)  // what arithmetic rules out fails before the run
    if (f < o.first || (f - o.first) % std::max(1, o.stride) != 0 ||
        (o.max_frames > 0 && (f - o.first) / std::max(1, o.stride) >= o.max_frames))
      throw not_evaluated(f);
  std::vector<int> drawn;
  const auto samples = Evaluate(o, {}, variants, [&](int frame, const auto& results) {
    if (o.images_dir.empty() || std::find(o.image_frames.begin(), o.image_frames.end(), frame) == o.image_frames.end())
      return;
    WriteFigure(o.images_dir + "/held_out_frame" + std::to_string(frame) + ".jpg", results, variants);
    drawn.push_back(frame);
  });
  // A figure asked for and not drawn (past the video's end, or its frame
  // incomplete) is missing output, not a quiet success.
  for (int f : o.image_frames)
    if (std::find(drawn.begin(), drawn.end(), f) == drawn.end()) throw not_evaluated(f);
  nlohmann::json j = {{"rig", o.rig}, {"stride", o.stride}, {"first", o.first}};
  std::vector<int> cameras;
  for (const auto& s : samples[0])
    if (std::find(cameras.begin(), cameras.end(), s.camera) == cameras.end()) cameras.push_back(s.camera);
  if (!o.json)
    std::printf("%-12s %-7s %9s %7s %7s %10s %9s %11s %11s %11s %8s\n", "variant", "camera", "PSNR dB", "SSIM", "IoU",
                "PSNR worst", "IoU worst", "PSNR cover", "SSIM cover", "PSNR black", "s/view");
  for (size_t v = 0; v < variants.size(); ++v) {
    nlohmann::json row = {{"variant", variants[v].name}, {"all", SummaryJson(Summarise(samples[v]))}};
    for (int c : cameras) {
      row["cameras"].push_back(SummaryJson(Summarise(samples[v], c)));
      row["cameras"].back()["id"] = c;
    }
    for (const auto& s : samples[v])
      row["samples"].push_back({{"frame", s.frame}, {"camera", s.camera}, {"psnr_db", s.psnr}, {"ssim", s.ssim},
                                {"iou", s.iou}, {"psnr_db_covered", s.psnr_covered}, {"ssim_covered", s.ssim_covered},
                                {"psnr_db_black", s.psnr_black}});
    j["variants"].push_back(row);
    if (o.json) continue;
    auto print = [&](const std::string& cam, const Summary& s) {
      std::printf("%-12s %-7s %9.2f %7.3f %7.3f %10.2f %9.3f %11.2f %11.3f %11.2f %8.3f\n", variants[v].name.c_str(),
                  cam.c_str(), s.psnr, s.ssim, s.iou, s.psnr_worst, s.iou_worst, s.psnr_covered, s.ssim_covered,
                  s.psnr_black, s.seconds);
    };
    for (int c : cameras) print(std::to_string(c), Summarise(samples[v], c));
    print("all", Summarise(samples[v]));
  }
  j["command"] = CommandLine();
  if (o.json) std::cout << j.dump(1) << std::endl;
  return 0;
}

int RunSegmentationEval(const HeldOutEvalOptions& o) {
  // A camera whose maps are given (masks) is not segmented: every setting
  // would print the same row.
  for (const RigCamera& c : LoadRig(o.rig).cameras)
    if (!c.masks.empty())
      throw std::invalid_argument(o.rig + ": camera " + std::to_string(c.camera.id) +
                                  "'s object-pixel maps are given (masks: " + c.masks +
                                  "), not segmented: the settings table needs a rig with background videos");
  struct Setting {
    std::string name;
    VideoRigOptions rig;
  };
  std::vector<Setting> settings;
  auto add = [&](const std::string& name, const std::function<void(VideoRigOptions*)>& change) {
    Setting s{name, {}};
    change(&s.rig);
    settings.push_back(s);
  };
  add("default", [](VideoRigOptions*) {});
  add("value 20", [](VideoRigOptions* r) { r->segmentation.value_threshold = 20; });
  add("value 45", [](VideoRigOptions* r) { r->segmentation.value_threshold = 45; });
  add("noise k 2", [](VideoRigOptions* r) { r->segmentation.value_noise_k = 2; });
  add("noise k 6", [](VideoRigOptions* r) { r->segmentation.value_noise_k = 6; });
  add("hue off", [](VideoRigOptions* r) { r->segmentation.hue_threshold = 90; });
  add("no shadows",
      [](VideoRigOptions* r) { r->segmentation.shadow_min_ratio = r->segmentation.shadow_max_ratio = 1; });
  add("open 0", [](VideoRigOptions* r) { r->segmentation.open_radius = 0; });
  add("close 0", [](VideoRigOptions* r) { r->segmentation.close_radius = 0; });
  add("close 6", [](VideoRigOptions* r) { r->segmentation.close_radius = 6; });
  add("no holes", [](VideoRigOptions* r) { r->segmentation.max_hole_fraction = 0; });
  add("components all", [](VideoRigOptions* r) { r->segmentation.min_component_ratio = 0; });
  add("adaptive 0.02", [](VideoRigOptions* r) { r->follow_files = true, r->background_rate = 0.02; });
  add("adaptive 0.05", [](VideoRigOptions* r) { r->follow_files = true, r->background_rate = 0.05; });
  Variant recon;
  recon.name = "blend2+vis";
  recon.options.visibility_width = 80;
  recon.options.threads = o.threads;
  nlohmann::json j = {{"rig", o.rig}, {"stride", o.stride}, {"first", o.first}, {"texturing", recon.name}};
  if (!o.json)
    std::printf("%-16s %9s %7s %7s %10s %9s %11s\n", "setting", "PSNR dB", "SSIM", "IoU", "PSNR worst", "IoU worst",
                "PSNR cover");
  for (const auto& s : settings) {
    s.rig.segmentation.Check();
    const Summary sum = Summarise(Evaluate(o, s.rig, {recon})[0]);
    nlohmann::json row = SummaryJson(sum);
    row["setting"] = s.name;
    j["settings"].push_back(row);
    if (!o.json)
      std::printf("%-16s %9.2f %7.3f %7.3f %10.2f %9.3f %11.2f\n", s.name.c_str(), sum.psnr, sum.ssim, sum.iou,
                  sum.psnr_worst, sum.iou_worst, sum.psnr_covered);
    std::fflush(stdout);
  }
  j["command"] = CommandLine();
  if (o.json) std::cout << j.dump(1) << std::endl;
  return 0;
}

}  // namespace hullpipe
