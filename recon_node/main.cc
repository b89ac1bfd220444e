// recon_node: renders its tile of the novel view's visual hull (paper §3.3).
// Parses flags and connects DDS to a ReconController (nodes/recon_controller.h),
// which holds the node's run-time logic: pose queue, sweep, texture, fail-over.
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/frameset_input.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/gl/backend.h"
#include "hullpipe/nodes/recon_controller.h"
#include "hullpipe/util/logging.h"

using namespace hullpipe;
using namespace hullpipe::dds;

namespace {

class TileWriter final : public nodes::ReconSink {
 public:
  explicit TileWriter(const Participant& p) : writer_(p) {}
  void PublishTile(const HullTile& tile, uint32_t planes) override {
    writer_.Write(MakeHullViewMessage(tile, planes).msg);
  }

 private:
  Writer<hullpipe_msg_HullView> writer_;
};

}  // namespace

int main(int argc, char** argv) {
  hullpipe::LogToStderr("recon");  // stdout carries only what a user asked for
  hullpipe::SetCommandLine(argc, argv);
  CLI::App app{"hullpipe recon_node: object-pixel maps + ViewPose -> HullView tile"};
  CommonOptions common;
  AddCommonOptions(app, common);
  AddRunIdOption(app, common);
  nodes::ReconOptions o;
  std::string tile_spec = "0/1", backend_name = "auto", out_of_view = "unknown";
  app.add_option("--tile", tile_spec, "This node's tile i/N of the view (horizontal bands)")->capture_default_str();
  app.add_option("--backend", backend_name, "Sweep backend: cpu|gl|auto")
      ->check(CLI::IsMember({"cpu", "gl", "auto"}))->capture_default_str();
  BackendOptions bo;
  app.add_option("--gl-method", bo.gl_method,
                 "GL sweep: march (compute-shader ray march, refinement on the GPU) or stencil (the paper's "
                 "stencil counting)")
      ->check(CLI::IsMember({"march", "stencil"}))->capture_default_str();
  app.add_option("--gl-device", bo.gl_device, "EGL device index for GL (-1: the first hardware device)")
      ->check(CLI::Range(-1, 64))->capture_default_str();
  app.add_option("--planes", o.sweep.num_planes, "Sweep planes")->capture_default_str();
  app.add_option("--threads", o.threads,
                 "CPU threads of the sweep, visibility maps and hull box (0: this host's cores shared among its "
                 "recon nodes)")
      ->capture_default_str();
  app.add_option("--refine", o.refine, "Depth refinement bisections after the sweep (0: the paper's plane depth)")
      ->check(CLI::Range(0, 30))->capture_default_str();
  app.add_option("--visibility-width", o.visibility_width,
                 "Width of each camera's hull depth map for the texture visibility test (0: no test)")
      ->check(CLI::Range(0, 4096))->capture_default_str();
  app.add_option("--out-of-view", out_of_view,
                 "A camera that cannot see a point: unknown (does not vote) or outside (vetoes, as the paper)")
      ->check(CLI::IsMember({"unknown", "outside"}))->capture_default_str();
  app.add_option("--failover", o.failover,
                 "A peer recon node silent (no NodeStats) this many s: the lowest live tile renders its tile too")
      ->capture_default_str();
  app.add_option("--pose-timeout", o.pose_timeout, "Drop a pose whose frameset has not arrived after this many s")
      ->capture_default_str();
  FramesetOptions frameset_options;
  AddFramesetOptions(app, frameset_options);
  CLI11_PARSE(app, argc, argv);

  try {
    o.ParseTile(tile_spec);
    o.out_of_view = out_of_view == "outside" ? OutOfView::kOutside : OutOfView::kUnknown;
    o.Check();
  } catch (const std::invalid_argument& e) {
    spdlog::error("{}", e.what());  // one line, as every node's bad flag (exit 1)
    return 1;
  }
  const std::string name = o.NodeName();
  try {
    auto participant = StartNode(name, common);
    bo.name = backend_name;
    bo.threads = std::max(1, o.threads);  // 0: decided per frameset (ReconController::ThreadsNow)
    bo.refine = o.refine;
    std::unique_ptr<SweepBackend> backend = gl::MakeSweepBackend(bo);
    backend->set_stop(StopRequestFlag());  // SIGINT ends a long sweep too
    spdlog::info("tile {}/{}, backend {} ({})", o.tile, o.tile_count, backend->Name(), backend->reason());
    WaitSet ws(*participant);
    FramesetInput input(*participant, ws, kFramesetHistory, /*with_images=*/true, frameset_options);
    Reader<hullpipe_msg_ViewPose> pose_reader(*participant);
    Reader<hullpipe_msg_NodeStats> peer_stats(*participant);
    ws.Attach(pose_reader);
    TileWriter tiles(*participant);
    SystemClock clock;
    o.run_id = common.run_id;
    nodes::ReconController recon(o, clock, input.assembler(), *backend, tiles);
    NodeReporter reporter(*participant, name, recon.counters(), common.run_id);
    input.SetCounters(&recon.counters());
    while (!StopRequested()) {
      ws.Wait(0.1);
      input.Poll();
      peer_stats.TakeEach([&](const hullpipe_msg_NodeStats& m, const dds_sample_info_t&) {
        recon.OnNodeStats(m.node_name ? m.node_name : "", m.final_report, m.run_id, m.host ? m.host : "");
      });
      pose_reader.TakeEach([&](const hullpipe_msg_ViewPose& m, const dds_sample_info_t&) {
        try {
          recon.OnPose(ViewFromMsg(m), m.pose_seq, m.frame_seq, m.run_id);
        } catch (const MessageError& e) {
          recon.Reject(e.what());
        }
      });
      recon.SetMalformedInput(input.malformed());
      try {
        recon.Step();
      } catch (const Interrupted& e) {
        spdlog::info("{}; stopping", e.what());
        break;
      }
      reporter.Publish();
    }
    reporter.Publish(true);
    uint64_t other_runs = 0;
    for (const auto& [kind, n] : recon.runs().ignored()) other_runs += n;
    spdlog::info("stopped: {} tiles out, {} dropped, {} rejected, {} sample(s) of other runs ignored",
                 recon.counters().frames_out(), recon.counters().dropped(), recon.counters().rejected(), other_runs);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
