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
#include "hullpipe/nodes/recon_flags.h"
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
  CLI::App app{"hullpipe recon_node: object-pixel maps + ViewPose -> HullView tile"};
  CommonOptions common;
  OpenCommandLine(argc, argv, "recon", app, common, /*with_run_id=*/true);
  nodes::ReconFlags flags;
  flags.Register(app);
  FramesetOptions frameset_options;
  AddFramesetOptions(app, frameset_options);
  CLI11_PARSE(app, argc, argv);
  try {
    flags.Resolve();
  } catch (const std::invalid_argument& e) {
    spdlog::error("{}", e.what());  // one line, as every node's bad flag (exit 1)
    return 1;
  }
  nodes::ReconOptions& o = flags.options;
  const std::string name = o.NodeName();
  try {
    auto participant = StartNode(name, common);
    std::unique_ptr<SweepBackend> backend = gl::MakeSweepBackend(flags.backend);
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
    if (frameset_options.input_thread) input.StartInputThread();
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
