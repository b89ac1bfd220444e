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
//   vh_eval run --rig DIR --run OUT [--exact-stride S] [--json]
// a pipeline run's composited hull (render_node --save-depth) against the same
// frames' hull computed here: the direct sweep, pixel for pixel, and the exact
// intervals (vh_eval_run.h).
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
#include "hullpipe/util/logging.h"
#include "hullpipe/util/memory.h"
#include "vh_eval_collision.h"
#include "vh_eval_held_out.h"
#include "vh_eval_reprojection.h"
#include "vh_eval_run.h"
#include "vh_eval_sweep.h"

using namespace hullpipe;

int main(int argc, char** argv) {
  hullpipe::LogToStderr("vh_eval");  // stdout carries only what a user asked for
  hullpipe::KeepFreedMemory();  // a loop over frames: no page faults per frame (util/memory.h)
  hullpipe::SetCommandLine(argc, argv);
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
  ReprojectionEvalOptions ro;
  auto* rep = app.add_subcommand("reprojection", "Per-camera IoU of the hull's reprojection with the maps");
  AddReprojectionOptions(rep, ro);
  RunEvalOptions rn;
  auto* run = app.add_subcommand(
      "run", "A pipeline run's composited hull against the same frames' direct sweep and exact hull");
  AddRunEvalOptions(run, rn);
  HeldOutEvalOptions ho;
  auto* held =
      app.add_subcommand("held-out", "Rendering error from each held-out camera's pose, per texturing variant");
  auto* seg = app.add_subcommand("segmentation", "Held-out rendering error per segmentation setting");
  for (auto* sub : {held, seg}) {
    sub->add_option("--rig", ho.rig, "Rig directory or YAML rig file")->required();
    sub->add_option("--stride", ho.stride, "Evaluate every S-th frame")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
    sub->add_option("--first", ho.first, "First frame evaluated (0-based)")
        ->check(CLI::Range(0, 100000000))
        ->capture_default_str();
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
  if (run->parsed()) {
    try {
      return RunRunEval(rn);
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
  try {
    return RunReprojectionEval(ro);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vh_eval: %s\n", e.what());
    return 1;
  }
}
