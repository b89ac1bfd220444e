// render_node: the parent pipe (paper §3–§4). Parses flags, connects DDS and the
// outputs (video, PNGs, window, stats.json) to a RenderController
// (nodes/render_controller.h), which holds all of the node's run-time logic.
#include <filesystem>
#include <fstream>
#include <type_traits>

#include <CLI/CLI.hpp>
#include <opencv2/highgui.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/geometry/calibration.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/frameset_input.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/nodes/render_controller.h"
#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/util/cli_range.h"

using namespace hullpipe;
using namespace hullpipe::dds;
namespace fs = std::filesystem;

namespace {

// ViewPose messages, and the video, PNGs and window.
class Outputs final : public nodes::RenderSink {
 public:
  Outputs(const Writer<hullpipe_msg_ViewPose>& poses, uint64_t run_id, std::string out_dir, double video_fps,
          int png_every, bool show, bool save_depth)
      : poses_(poses),
        run_id_(run_id),
        out_dir_(std::move(out_dir)),
        video_fps_(video_fps),
        png_every_(png_every),
        show_(show),
        save_depth_(save_depth) {}
  void PublishPose(const NovelView& view, uint64_t pose_seq, uint64_t frame_seq) override {
    poses_.Write(ViewToMsg(view, pose_seq, frame_seq, NowNs(), run_id_));
  }
  void WriteFrame(const cv::Mat& frame, uint64_t frame_seq, uint64_t count, const NovelView& view,
                  const cv::Mat& hull_depth, double path_time_s) override {
    if (!video_.isOpened() && !video_failed_) {
      video_.open(video_path(), cv::VideoWriter::fourcc('m', 'p', '4', 'v'), video_fps_, frame.size());
      if (!video_.isOpened()) {
        video_failed_ = true;
        Failed(video_path());
      }
    }
    if (video_.isOpened()) {
      video_.write(frame);
      ++video_frames_;
    }
    if (png_every_ > 0 && count % uint64_t(png_every_) == 1 % uint64_t(png_every_)) {
      const std::string stem = (fs::path(out_dir_) / cv::format("frame_%05llu", (unsigned long long)frame_seq)).string();
      Write(stem + ".png", frame);
      if (save_depth_) {
        // The hull's eye-z depth (float TIFF, metres, +inf: no hull) and the view
        // it was seen from, so the frame can be checked against a reference.
        Write(stem + "_depth.tiff", hull_depth);
        if (!views_.is_open()) {
          views_.open((fs::path(out_dir_) / "views.csv").string());
          views_ << "frame_seq,path_time_s,width,height,fx,fy,cx,cy,"
                    "r00,r01,r02,r10,r11,r12,r20,r21,r22,tx,ty,tz\n";
        }
        const Eigen::Matrix3d& R = view.world_from_eye.rotation;
        const Eigen::Vector3d& t = view.world_from_eye.translation;
        views_ << frame_seq << ',' << cv::format("%.9f", path_time_s) << ',' << view.width << ',' << view.height;
        for (double x : {view.fx, view.fy, view.cx, view.cy, R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2),
                         R(2, 0), R(2, 1), R(2, 2), t.x(), t.y(), t.z()})
          views_ << ',' << cv::format("%.17g", x);
        views_ << '\n' << std::flush;
      }
    }
    if (show_) {
      try {
        cv::imshow("hullpipe", frame);
        cv::waitKey(1);
      } catch (const cv::Exception& e) {
        spdlog::warn("cannot open a window ({}); continuing without", e.what());
        show_ = false;
      }
    }
  }
  std::string video_path() const { return (fs::path(out_dir_) / "hullpipe.mp4").string(); }
  void Close() { video_.release(); }
  int64_t video_frames() const { return video_frames_; }
  /// Output files that could not be written (the video, PNGs, depth TIFFs), and the first.
  int64_t failures() const { return failures_; }
  const std::string& first_failure() const { return first_failure_; }

 private:
  const Writer<hullpipe_msg_ViewPose>& poses_;
  uint64_t run_id_;
  std::string out_dir_;
  double video_fps_;
  int png_every_;
  bool show_;
  bool save_depth_;
  cv::VideoWriter video_;
  bool video_failed_ = false;
  int64_t video_frames_ = 0;
  std::ofstream views_;
  int64_t failures_ = 0;
  std::string first_failure_;

  void Write(const std::string& path, const cv::Mat& image) {
    bool ok = false;
    try {
      ok = cv::imwrite(path, image);
    } catch (const cv::Exception&) {
      ok = false;
    }
    if (!ok) Failed(path);
  }
  void Failed(const std::string& path) {
    if (failures_++ == 0) {
      first_failure_ = path;
      spdlog::error("cannot write {} (further failures are counted)", path);
    }
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hullpipe render_node: viewpoint, tile assembly, compositing, outputs"};
  CommonOptions common;
  AddCommonOptions(app, common);
  AddRunIdOption(app, common);
  nodes::RenderOptions o;
  std::string out_dir = "out", window = "auto", view_source = "orbit", head_poses, scene_path;
  int png_every = 0;
  bool save_depth = false;
  double video_fps = 15;
  std::vector<double> orbit_centre, up{0, 0, -1};
  app.add_option("--out", out_dir, "Output directory (video, PNGs, stats.json)")->capture_default_str();
  app.add_option("--frames", o.max_frames, "Stop after compositing the frameset with this sequence number");
  app.add_option("--width", o.width, "Novel view width")->capture_default_str();
  app.add_option("--height", o.height, "Novel view height")->capture_default_str();
  app.add_option("--hfov", o.hfov_deg, "Horizontal field of view, degrees")->capture_default_str();
  app.add_option("--tiles", o.tiles, "Recon tiles per frame (number of recon nodes)")->capture_default_str();
  app.add_option("--max-in-flight", o.max_in_flight, "Poses rendered concurrently")->capture_default_str();
  app.add_option("--png-every", png_every, "Write every K-th composited frame as PNG (0: none)")
      ->check(CLI::Range(0, 1000000));
  app.add_flag("--save-depth", save_depth,
               "With each PNG, the hull's depth (frame_N_depth.tiff, float eye z in metres) and its view (views.csv: "
               "K, world_from_eye)");
  app.add_option("--video-fps", video_fps, "Frame rate written into the video")
      ->check(hullpipe::FiniteRange(1.0, 1000.0))
      ->capture_default_str();
  app.add_option("--idle-timeout", o.idle_timeout, "Stop when no new frameset came for this many s")
      ->capture_default_str();
  app.add_option("--tile-timeout", o.tile_timeout, "Give up on a pose's missing tiles after this many s")
      ->capture_default_str();
  app.add_option("--orbit-centre", orbit_centre, "Orbit centre x,y,z in world metres (default: hull box centre)")
      ->delimiter(',')->expected(3);
  app.add_option("--orbit-radius", o.orbit_radius, "Orbit radius, metres")->capture_default_str();
  app.add_option("--orbit-height", o.orbit_height, "Eye height above the centre, metres")->capture_default_str();
  app.add_option("--orbit-period", o.orbit_period, "Seconds per turn (frame time)")->capture_default_str();
  app.add_option("--view", view_source,
                 "Viewpoint: orbit (scripted), file (--head-poses CSV), topic (HeadPose from a tracker; "
                 "the orbit until the first arrives)")
      ->check(CLI::IsMember({"orbit", "file", "topic"}))->capture_default_str();
  app.add_option("--head-poses", head_poses,
                 "Tracked head poses, CSV t,x,y,z,qw,qx,qy,qz (world_from_eye, OpenCV eye frame; t in seconds "
                 "from the first frame)");
  app.add_option("--scene", scene_path, "Scene file: render_node uses its `light` (shadows); sim_node the rest");
  auto* up_opt = app.add_option("--up", up, "World up vector (default: the rig's; Utrecht rig: 0,0,-1)")
                     ->delimiter(',')
                     ->expected(3);
  std::string rig_path, floor_text;
  app.add_option("--rig", rig_path,
                 "Rig directory or YAML rig file: its world (up, floor, orbit) unless the flags say otherwise "
                 "(default: the Utrecht rig's world)");
  app.add_option("--floor", floor_text, "Floor: metres along up (plane up . x = H), 'hull' (under the first hull) or "
                                        "'none' (default: the rig's; Utrecht: 0)");
  app.add_option("--window", window, "Show the output in a window: auto (where a display exists), on, off")
      ->check(CLI::IsMember({"auto", "on", "off"}))->capture_default_str();
  double skew_tolerance_ms = 0;
  app.add_option("--skew-tolerance", skew_tolerance_ms,
                 "Largest |capture time - reference time| of a frameset's maps, ms (0: half the slowest camera's "
                 "frame period)")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  try {
    if ((view_source == "file") != !head_poses.empty())
      throw std::invalid_argument("--view file goes with --head-poses FILE");
    o.view = view_source == "file"    ? nodes::RenderOptions::View::kFile
             : view_source == "topic" ? nodes::RenderOptions::View::kTopic
                                      : nodes::RenderOptions::View::kOrbit;
    if (!head_poses.empty()) o.track = LoadPoseTrack(head_poses);
    if (!scene_path.empty()) o.light = LoadSceneConfig(scene_path).light;
    if (!rig_path.empty()) {
      const RigWorld w = LoadRig(rig_path).world;
      if (!up_opt->count()) up = {w.up.x(), w.up.y(), w.up.z()};
      o.floor = w.floor;
      o.floor_height = w.floor_height;
      if (!app.get_option("--orbit-radius")->count()) o.orbit_radius = w.orbit_radius;
      if (!app.get_option("--orbit-height")->count()) o.orbit_height = w.orbit_height;
    }
    if (!floor_text.empty()) {
      if (floor_text == "hull" || floor_text == "none") {
        o.floor = floor_text == "hull" ? RigWorld::Floor::kUnderHull : RigWorld::Floor::kNone;
      } else {
        try {
          size_t used = 0;
          o.floor_height = std::stod(floor_text, &used);
          if (used != floor_text.size()) throw std::invalid_argument("");
        } catch (const std::exception&) {
          throw std::invalid_argument("--floor must be metres along up, 'hull' or 'none', not '" + floor_text + "'");
        }
        o.floor = RigWorld::Floor::kPlane;
      }
    }
    if (orbit_centre.size() == 3) o.orbit_centre = Eigen::Vector3d(orbit_centre[0], orbit_centre[1], orbit_centre[2]);
    o.up = Eigen::Vector3d(up[0], up[1], up[2]);
    o.Check();
    auto participant = StartNode("render", common);
    const bool have_display = std::getenv("DISPLAY") || std::getenv("WAYLAND_DISPLAY");
    fs::create_directories(out_dir);
    WaitSet ws(*participant);
    FramesetInput input(*participant, ws, kFramesetHistory, false);
    if (!(skew_tolerance_ms >= 0 && skew_tolerance_ms <= 1000))
      throw std::invalid_argument("--skew-tolerance must be in [0, 1000] ms");
    input.assembler().SetTolerance(skew_tolerance_ms * 1e-3);
    Reader<hullpipe_msg_HullView> tile_reader(*participant);
    Reader<hullpipe_msg_VirtualObjectState> state_reader(*participant);
    Reader<hullpipe_msg_CollisionReport> report_reader(*participant);
    Reader<hullpipe_msg_NodeStats> stats_reader(*participant);
    Reader<hullpipe_msg_VirtualMesh> mesh_reader(*participant);
    Reader<hullpipe_msg_HeadPose> head_reader(*participant);
    Writer<hullpipe_msg_ViewPose> pose_writer(*participant);
    ws.Attach(tile_reader);
    ws.Attach(state_reader);
    ws.Attach(report_reader);
    ws.Attach(stats_reader);
    ws.Attach(mesh_reader);
    // Poses carry this run's id and tiles echo it (nodes/run_filter.h): without
    // --run-id, render's own random one still tells its tiles from a replay's.
    o.run_id = common.run_id ? common.run_id : NewRunId();
    spdlog::info("run id {}{}", RunIdText(o.run_id), common.run_id ? "" : " (its own: no --run-id given)");
    Outputs outputs(pose_writer, o.run_id, out_dir, video_fps, png_every, window == "on" || (window == "auto" && have_display),
                    save_depth);
    SystemClock clock;
    nodes::RenderController render(o, clock, input.assembler(), outputs);
    NodeReporter reporter(*participant, "render", render.counters(), o.run_id);
    input.SetCounters(&render.counters());

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
      take(state_reader, [&](const hullpipe_msg_VirtualObjectState& m) { render.OnObjectState(VirtualObjectFromMsg(m)); });
      take(head_reader, [&](const hullpipe_msg_HeadPose& m) { render.OnHeadPose(HeadPoseFromMsg(m)); });
      take(mesh_reader, [&](const hullpipe_msg_VirtualMesh& m) { render.OnMesh(VirtualMeshFromMsg(m)); });
      take(report_reader, [&](const hullpipe_msg_CollisionReport& m) { render.OnCollisionReport(m.collision_points._length > 0); });
      take_stats();
      render.SetMalformedInput(input.malformed());
      composited = render.Step();
      if (clock.Now() - last_progress_s >= 1.0) {
        last_progress_s = clock.Now();
        const auto& c = render.counters();
        spdlog::info("frame {} | composited {} | {:.1f} fps | latency p50 {:.0f} ms p95 {:.0f} ms | dropped {}",
                     render.last_composited(), c.frames_out(), c.fps(), c.latency_ms().Percentile(50),
                     c.latency_ms().Percentile(95), c.dropped());
      }
      reporter.Publish();
    }
    outputs.Close();

    // Collect a last round of NodeStats (periodic reports are at most 0.5 s old).
    const double until = clock.Now() + 0.7;
    while (clock.Now() < until) {
      ws.Wait(0.05);
      take_stats();
    }
    nlohmann::json j = render.StatsJson();
    j["video"] = outputs.video_path();
    const std::string stats_path = (fs::path(out_dir) / "stats.json").string();
    // stats.json and the budget's waterfall rows (latency.tsv, for
    // scripts/latency_plot.sh); a file that cannot be written fails the run.
    const std::string budget_path = (fs::path(out_dir) / "latency.tsv").string();
    std::string unwritten;
    for (const auto& [path, text] :
         {std::pair{stats_path, j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n"},
          std::pair{budget_path, render.Budget().WaterfallTsv()}}) {
      std::ofstream f(path);
      f << text;
      f.close();
      if (!f) unwritten += (unwritten.empty() ? "" : ", ") + path;
    }
    std::printf("\n%s\nvideo: %s\nstats: %s\n", render.Table().c_str(),
                outputs.video_frames() > 0 ? outputs.video_path().c_str() : "none (no frame written)",
                stats_path.c_str());
    std::fflush(stdout);
    reporter.Publish(true);
    // Missing output is a failure, not an exit 0 (an interrupted run that
    // composited nothing has nothing to miss).
    if (!unwritten.empty()) {
      spdlog::error("could not write {}", unwritten);
      return 1;
    }
    if (outputs.failures() > 0) {
      spdlog::error("{} output file(s) could not be written, the first {}", outputs.failures(),
                    outputs.first_failure());
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
