// render_node: the parent pipe (paper §3–§4). Parses flags, connects DDS and the
// outputs (video, PNGs, window, stats.json) to a RenderController
// (nodes/render_controller.h), which holds all of the node's run-time logic.
#include <filesystem>
#include <type_traits>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/frameset_input.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/nodes/render_flags.h"
#include "hullpipe/util/logging.h"

using namespace hullpipe;
using namespace hullpipe::dds;
namespace fs = std::filesystem;

namespace {

// ViewPose and CompositedView messages on DDS; the video, PNGs and window in RenderOutputs.
class Outputs final : public nodes::RenderSink {
 public:
  Outputs(const Writer<hullpipe_msg_ViewPose>& poses, const Writer<hullpipe_msg_CompositedView>& views,
          const nodes::RenderOptions& o, nodes::RenderOutputs& files)
      : poses_(poses), views_(views), o_(o), files_(files) {}
  void PublishPose(const NovelView& view, uint64_t pose_seq, uint64_t frame_seq, ViewEye eye,
                   int64_t stamp_ns) override {
    poses_.Write(ViewToMsg(view, pose_seq, frame_seq, stamp_ns != 0 ? stamp_ns : NowNs(), o_.run_id, eye));
  }
  void WriteFrame(const cv::Mat& frame, uint64_t frame_seq, uint64_t count, const NovelView& view,
                  const cv::Mat& hull_depth, double path_time_s, const RightEye* right) override {
    files_.WriteFrame(frame, frame_seq, count, view, hull_depth, path_time_s, right);
  }
  void PublishComposite(const cv::Mat& frame, uint64_t pose_seq, uint64_t frame_seq, int64_t capture_time_ns,
                        ViewEye eye) override {
    if (views_.MatchedReaders() == 0) return;  // no viewer or recorder: no JPEG to encode
    views_.Write(MakeCompositedViewMessage(frame, pose_seq, frame_seq, capture_time_ns, o_.run_id,
                                           {o_.publish_max_side, o_.publish_jpeg_quality}, eye)
                     .msg);
  }

 private:
  const Writer<hullpipe_msg_ViewPose>& poses_;
  const Writer<hullpipe_msg_CompositedView>& views_;
  const nodes::RenderOptions& o_;
  nodes::RenderOutputs& files_;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hullpipe render_node: viewpoint, tile assembly, compositing, outputs"};
  CommonOptions common;
  OpenCommandLine(argc, argv, "render", app, common, /*with_run_id=*/true);
  nodes::RenderFlags flags;
  flags.Register(app);
  FramesetOptions frameset_options;
  AddFramesetOptions(app, frameset_options);
  CLI11_PARSE(app, argc, argv);

  try {
    flags.Resolve(std::getenv("DISPLAY") || std::getenv("WAYLAND_DISPLAY"));
    nodes::RenderOptions& o = flags.options;
    auto participant = StartNode("render", common);
    nodes::RenderOutputs files(flags.outputs);
    WaitSet ws(*participant);
    FramesetInput input(*participant, ws, kFramesetHistory, false, frameset_options);
    Reader<hullpipe_msg_HullView> tile_reader(*participant);
    Reader<hullpipe_msg_VirtualObjectState> state_reader(*participant);
    Reader<hullpipe_msg_CollisionReport> report_reader(*participant);
    Reader<hullpipe_msg_NodeStats> stats_reader(*participant);
    Reader<hullpipe_msg_VirtualMesh> mesh_reader(*participant);
    Reader<hullpipe_msg_HeadPose> head_reader(*participant);
    Reader<hullpipe_msg_EyeViews> eyes_reader(*participant);
    Reader<hullpipe_msg_ModelPart> part_reader(*participant);
    Reader<hullpipe_msg_ModelState> model_reader(*participant);
    Writer<hullpipe_msg_ViewPose> pose_writer(*participant);
    Writer<hullpipe_msg_CompositedView> view_writer(*participant);
    ws.Attach(tile_reader);
    ws.Attach(state_reader);
    ws.Attach(report_reader);
    ws.Attach(stats_reader);
    ws.Attach(mesh_reader);
    ws.Attach(part_reader);
    ws.Attach(model_reader);
    // Poses carry this run's id and tiles echo it (nodes/run_filter.h): without
    // --run-id, render's own random one still tells its tiles from a replay's.
    o.run_id = common.run_id ? common.run_id : NewRunId();
    spdlog::info("run id {}{}", RunIdText(o.run_id), common.run_id ? "" : " (its own: no --run-id given)");
    Outputs outputs(pose_writer, view_writer, o, files);
    SystemClock clock;
    nodes::RenderController render(o, clock, input.assembler(), outputs);
    render.set_stop(StopRequestFlag());  // SIGINT ends a long composite too
    NodeReporter reporter(*participant, "render", render.counters(), o.run_id);
    input.SetCounters(&render.counters());
    if (frameset_options.input_thread) input.StartInputThread();

    // Converts one sample (use(m), or use(m, info) when it wants the sample
    // info); a malformed one is rejected on one line.
    auto take = [&render](auto& reader, auto&& use) {
      reader.TakeEach([&](const auto& m, const dds_sample_info_t& info) {
        try {
          if constexpr (std::is_invocable_v<decltype(use), decltype(m), const dds_sample_info_t&>)
            use(m, info);
          else
            use(m);
        } catch (const MessageError& e) {
          render.Reject(e.what());
        }
      });
    };
    auto take_stats = [&] {
      take(stats_reader, [&](const hullpipe_msg_NodeStats& m) { render.OnNodeStats(NodeStatsFromMsg(m)); });
    };
    double last_progress_s = clock.Now();
    int composited = 0;
    while (!StopRequested() && !render.done()) {
      // Right after compositing, loop at once: a new pose may be issued now.
      if (composited == 0) ws.Wait(0.05);
      input.Poll();
      take(tile_reader, [&](const hullpipe_msg_HullView& m, const dds_sample_info_t& info) {
        render.OnTile(TileFromMsg(m), info.source_timestamp);
      });
      take(state_reader,
           [&](const hullpipe_msg_VirtualObjectState& m) { render.OnObjectState(VirtualObjectFromMsg(m)); });
      take(head_reader, [&](const hullpipe_msg_HeadPose& m) { render.OnHeadPose(HeadPoseFromMsg(m), m.stamp_ns); });
      take(eyes_reader, [&](const hullpipe_msg_EyeViews& m) { render.OnEyeViews(EyeViewsFromMsg(m)); });
      take(mesh_reader, [&](const hullpipe_msg_VirtualMesh& m) { render.OnMesh(VirtualMeshFromMsg(m)); });
      take(part_reader, [&](const hullpipe_msg_ModelPart& m) { render.OnModelPart(ModelPartFromMsg(m)); });
      take(model_reader, [&](const hullpipe_msg_ModelState& m) { render.OnModelState(ModelStateFromMsg(m)); });
      take(report_reader, [&](const hullpipe_msg_CollisionReport& m) {
        render.OnCollisionReport(m.collision_points._length > 0, m.has_response ? m.hull_velocity_status : 0,
                                 m.hull_normal_speed);
      });
      take_stats();
      render.SetMalformedInput(input.malformed());
      try {
        composited = render.Step();
      } catch (const Interrupted& e) {
        spdlog::info("{}; stopping (that frame is not written)", e.what());
        break;
      }
      if (clock.Now() - last_progress_s >= 1.0) {
        last_progress_s = clock.Now();
        const auto& c = render.counters();
        spdlog::info("frame {} | composited {} | {:.1f} fps | latency p50 {:.0f} ms p95 {:.0f} ms | dropped {}",
                     render.last_composited(), c.frames_out(), c.fps(), c.latency_ms().Percentile(50),
                     c.latency_ms().Percentile(95), c.dropped());
      }
      reporter.Publish();
    }
    files.Close();

    // Collect a last round of NodeStats (periodic reports are at most 0.5 s
    // old): until every peer heard from has sent its final report, 0.7 s at
    // most (a node stops within a second of SIGINT).
    const double until = clock.Now() + 0.7;
    while (clock.Now() < until && render.AwaitingFinalReports()) {
      ws.Wait(0.05);
      take_stats();
    }
    nlohmann::json j = render.StatsJson();
    j["video"] = files.video_path();
    // stats.json and the budget's waterfall rows (latency.tsv, for
    // scripts/latency_plot.sh); a file that cannot be written fails the run.
    files.WriteTextFile("stats.json", j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
    files.WriteTextFile("latency.tsv", render.Budget().WaterfallTsv());
    std::printf("\n%s\nvideo: %s\nstats: %s\n", render.Table().c_str(),
                files.video_frames() > 0 ? files.video_path().c_str() : "none (no frame written)",
                (fs::path(flags.outputs.out_dir) / "stats.json").c_str());
    std::fflush(stdout);
    reporter.Publish(true);
    // Missing output is a failure, not an exit 0 (an interrupted run that
    // composited nothing has nothing to miss).
    if (files.failures() > 0) {
      spdlog::error("{} output file(s) could not be written, the first {}", files.failures(), files.first_failure());
      return 1;
    }
    if (render.counters().frames_out() == 0 && !StopRequested()) {
      spdlog::error("no frame composited, so no video: no complete frameset and tiles came (see capture and recon)");
      return 1;
    }
    if (const std::string early = render.IncompleteInput(); !early.empty() && !StopRequested()) {
      spdlog::error("{}", early);
      return 3;
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
