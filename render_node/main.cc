// render_node: the parent pipe (paper §3–§4). It owns the user's viewpoint and
// publishes a ViewPose per output frame naming the newest complete frameset;
// assembles the recon nodes' HullView tiles of that pose; composites the textured
// hull with the virtual objects (depth test, colliding objects red); writes the
// video, optional PNGs and stats.json (every node's NodeStats plus its own).
#include <filesystem>
#include <limits>
#include <fstream>
#include <algorithm>
#include <map>
#include <memory>
#include <optional>
#include <set>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/highgui.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/reconstruction/compositor.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/frameset_input.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/reconstruction/frameset.h"
#include "hullpipe/geometry/head_pose.h"
#include "hullpipe/scenes/virtual_scene.h"

using namespace hullpipe;
using namespace hullpipe::dds;
namespace fs = std::filesystem;

namespace {

struct InFlight {
  uint64_t frame_seq = 0;
  int64_t capture_time_ns = 0;
  double sent_s = 0;
  NovelView view;
  std::map<uint32_t, HullTile> tiles;  // by tile index
  std::shared_ptr<const VolumeQuery> hull;  // for the light's shadow map
};

struct NodeRow {
  std::string name;
  double fps = 0, p50 = 0, p95 = 0;
  uint64_t in = 0, out = 0, dropped = 0, rejected = 0;
  nlohmann::json stages = nlohmann::json::object();
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hullpipe render_node: viewpoint, tile assembly, compositing, outputs"};
  CommonOptions common;
  AddCommonOptions(app, common);
  std::string out_dir = "out";
  int64_t max_frames = 0;
  int width = 320, height = 240, tiles = 2, png_every = 0, max_in_flight = 2;
  double hfov_deg = 50, idle_timeout = 5, tile_timeout = 1.0, video_fps = 15;
  double orbit_radius = 3.0, orbit_height = 0.7, orbit_period = 12.0;
  std::vector<double> orbit_centre, up{0, 0, -1};
  std::string window = "auto", view_source = "orbit", head_poses, scene_path;
  app.add_option("--out", out_dir, "Output directory (video, PNGs, stats.json)")->capture_default_str();
  app.add_option("--frames", max_frames, "Stop after compositing the frameset with this sequence number");
  app.add_option("--width", width, "Novel view width")->capture_default_str();
  app.add_option("--height", height, "Novel view height")->capture_default_str();
  app.add_option("--hfov", hfov_deg, "Horizontal field of view, degrees")->capture_default_str();
  app.add_option("--tiles", tiles, "Recon tiles per frame (number of recon nodes)")->capture_default_str();
  app.add_option("--max-in-flight", max_in_flight, "Poses rendered concurrently")->capture_default_str();
  app.add_option("--png-every", png_every, "Write every K-th composited frame as PNG (0: none)");
  app.add_option("--video-fps", video_fps, "Frame rate written into the video")->capture_default_str();
  app.add_option("--idle-timeout", idle_timeout, "Stop when no new frameset came for this many s")
      ->capture_default_str();
  app.add_option("--tile-timeout", tile_timeout, "Give up on a pose's missing tiles after this many s")
      ->capture_default_str();
  app.add_option("--orbit-centre", orbit_centre, "Orbit centre x,y,z in world metres (default: hull box centre)")
      ->delimiter(',')->expected(3);
  app.add_option("--orbit-radius", orbit_radius, "Orbit radius, metres")->capture_default_str();
  app.add_option("--orbit-height", orbit_height, "Eye height above the centre, metres")->capture_default_str();
  app.add_option("--orbit-period", orbit_period, "Seconds per turn (frame time)")->capture_default_str();
  app.add_option("--view", view_source,
                 "Viewpoint: orbit (scripted), file (--head-poses CSV), topic (HeadPose from a tracker; "
                 "the orbit until the first arrives)")
      ->check(CLI::IsMember({"orbit", "file", "topic"}))->capture_default_str();
  app.add_option("--head-poses", head_poses,
                 "Tracked head poses, CSV t,x,y,z,qw,qx,qy,qz (world_from_eye, OpenCV eye frame; t in seconds "
                 "from the first frame)");
  app.add_option("--scene", scene_path, "Scene file: render_node uses its `light` (shadows); sim_node the rest");
  app.add_option("--up", up, "World up vector (Utrecht rig: 0,0,-1)")->delimiter(',')->expected(3);
  app.add_option("--window", window, "Show the output in a window: auto (where a display exists), on, off")
      ->check(CLI::IsMember({"auto", "on", "off"}))->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  try {
    if ((view_source == "file") != !head_poses.empty())
      throw std::runtime_error("--view file goes with --head-poses FILE");
    const PoseTrack track = head_poses.empty() ? PoseTrack{} : LoadPoseTrack(head_poses);
    const std::optional<LightConfig> light = scene_path.empty() ? std::nullopt : LoadSceneConfig(scene_path).light;
    auto participant = StartNode("render", common);
    const bool have_display = std::getenv("DISPLAY") || std::getenv("WAYLAND_DISPLAY");
    bool show = window == "on" || (window == "auto" && have_display);
    fs::create_directories(out_dir);
    WaitSet ws(*participant);
    FramesetInput input(*participant, ws, 8, false);
    FramesetAssembler& assembler = input.assembler();
    Reader<hullpipe_msg_HullView> tile_reader(*participant);
    Reader<hullpipe_msg_VirtualObjectState> state_reader(*participant);
    Reader<hullpipe_msg_CollisionReport> report_reader(*participant);
    Reader<hullpipe_msg_NodeStats> stats_reader(*participant);
    Reader<hullpipe_msg_VirtualMesh> mesh_reader(*participant);
    Reader<hullpipe_msg_HeadPose> head_reader(*participant);
    std::optional<Rigid3d> tracked;  // newest HeadPose (--view topic)
    Writer<hullpipe_msg_ViewPose> pose_writer(*participant);
    ws.Attach(tile_reader);
    ws.Attach(state_reader);
    ws.Attach(report_reader);
    ws.Attach(stats_reader);
    ws.Attach(mesh_reader);
    NodeReporter reporter(*participant, "render");

    OrbitPath orbit;
    orbit.up = Eigen::Vector3d(up[0], up[1], up[2]);
    orbit.radius = orbit_radius;
    orbit.height = orbit_height;
    orbit.period = orbit_period;
    bool centre_known = orbit_centre.size() == 3;
    if (centre_known) orbit.centre = Eigen::Vector3d(orbit_centre[0], orbit_centre[1], orbit_centre[2]);
    CompositeOptions comp;
    comp.floor_normal = orbit.up.normalized();

    std::map<uint64_t, InFlight> in_flight;
    std::map<uint32_t, std::map<uint64_t, hullpipe_msg_VirtualObjectState>> states;  // object -> frame -> state
    std::map<uint32_t, std::map<uint64_t, VirtualMeshSample>> meshes;  // object -> frame -> mesh
    std::map<uint32_t, double> min_clearance;     // payload part -> least clearance seen, metres
    std::map<uint32_t, uint64_t> part_collisions;  // payload part -> frames drawn colliding
    std::map<std::string, hullpipe_msg_NodeStats> node_stats;
    std::map<std::string, nlohmann::json> node_stages;
    std::map<std::string, double> recon_heard;     // recon node -> when its NodeStats last came
    std::map<std::string, bool> recon_silent;
    std::map<std::string, int> recon_outages;
    uint64_t seen_restarts = 0;
    uint64_t pose_seq = 0, last_requested = 0, last_composited = 0, rejected = 0, tiles_late = 0;
    uint64_t collisions_drawn = 0, collision_reports = 0, meshes_drawn = 0, lit_frames = 0;
    double hull_fraction_sum = 0;  // fraction of view pixels showing hull, summed over frames
    double first_source_time = 0;
    double last_new_frame_s = MonotonicSeconds(), last_progress_s = MonotonicSeconds();
    bool any_frame = false, done = false, capture_done = false;
    double capture_done_s = 0;
    cv::VideoWriter video;
    const std::string video_path = (fs::path(out_dir) / "hullpipe.mp4").string();

    auto reject = [&](const std::string& why) {
      ++rejected;
      spdlog::warn("rejected: {}", why);
    };
    // Keeps the newest NodeStats of every node (strings copied out of the loan).
    auto take_stats = [&] {
      stats_reader.TakeEach([&](const hullpipe_msg_NodeStats& m, const dds_sample_info_t&) {
        const std::string name = m.node_name ? m.node_name : "";
        nlohmann::json st = nlohmann::json::object();
        for (uint32_t i = 0; i < m.stages._length; ++i) {
          const auto& stage = m.stages._buffer[i];
          st[stage.name ? stage.name : "?"] = {{"ms_mean", stage.ms_mean}, {"ms_p95", stage.ms_p95}};
        }
        node_stages[name] = st;
        if (name.rfind("recon", 0) == 0) recon_heard[name] = m.final_report ? -1e9 : MonotonicSeconds();
        hullpipe_msg_NodeStats copy = m;
        copy.node_name = nullptr;
        copy.stages = {};
        node_stats[name] = copy;
        if (m.final_report && name.rfind("capture", 0) == 0 && !capture_done) {
          capture_done = true;
          capture_done_s = MonotonicSeconds();
          spdlog::info("{} reports the end of its input", name);
        }
      });
    };

    bool composited_last_round = false;
    while (!StopRequested() && !done) {
      // Right after compositing, loop at once: a new pose may be issued now.
      if (!composited_last_round) ws.Wait(0.05);
      composited_last_round = false;
      input.Poll();
      tile_reader.TakeEach([&](const hullpipe_msg_HullView& m, const dds_sample_info_t&) {
        try {
          HullTile t = TileFromMsg(m);
          auto it = in_flight.find(t.pose_seq);
          if (it == in_flight.end()) {
            ++tiles_late;
            return;
          }
          if (t.rect.x + t.rect.width > it->second.view.width || t.rect.y + t.rect.height > it->second.view.height)
            throw MessageError("HullView tile rectangle lies outside the view");
          it->second.tiles[t.tile_index] = std::move(t);
        } catch (const MessageError& e) {
          reject(e.what());
        }
      });
      state_reader.TakeEach([&](const hullpipe_msg_VirtualObjectState& m, const dds_sample_info_t&) {
        auto& per = states[m.object_id];
        per[m.frame_seq] = m;
        while (per.size() > 32) per.erase(per.begin());
      });
      head_reader.TakeEach([&](const hullpipe_msg_HeadPose& m, const dds_sample_info_t&) {
        try {
          tracked = HeadPoseFromMsg(m);
        } catch (const MessageError& e) {
          reject(e.what());
        }
      });
      mesh_reader.TakeEach([&](const hullpipe_msg_VirtualMesh& m, const dds_sample_info_t&) {
        try {
          VirtualMeshSample v = VirtualMeshFromMsg(m);
          auto& per = meshes[v.object_id];
          per[v.frame_seq] = std::move(v);
          while (per.size() > 8) per.erase(per.begin());
        } catch (const MessageError& e) {
          reject(e.what());
        }
      });
      report_reader.TakeEach([&](const hullpipe_msg_CollisionReport& m, const dds_sample_info_t&) {
        if (m.collision_points._length > 0) ++collision_reports;
      });
      take_stats();

      // A restarted capture numbers its frames from 1 again.
      if (assembler.restarts() != seen_restarts) {
        seen_restarts = assembler.restarts();
        last_requested = 0;
        spdlog::info("capture restarted: following its new frame numbers");
      }
      // Issue new poses for new complete framesets.
      while (int(in_flight.size()) < max_in_flight) {
        const auto newest = assembler.NewestComplete();
        if (!newest || *newest <= last_requested) break;
        auto fset = assembler.Take(*newest);
        if (!fset) break;
        reporter.FrameIn();
        last_new_frame_s = MonotonicSeconds();
        if (!any_frame) {
          any_frame = true;
          first_source_time = fset->source_time_s;
        }
        // The frameset's hull: for the orbit centre until it is known, and for
        // the light's shadow map (one VolumeQuery, one hull box, for both).
        std::shared_ptr<const VolumeQuery> hull;
        if (light || !centre_known) hull = std::make_shared<const VolumeQuery>(fset->maps, assembler.workspace());
        if (!centre_known) {
          if (!hull->hull_box().empty()) {
            orbit.centre = hull->hull_box().Center();
            centre_known = true;
            spdlog::info("orbit centre from the hull box: [{:.2f}, {:.2f}, {:.2f}] m", orbit.centre.x(),
                         orbit.centre.y(), orbit.centre.z());
          }
        }
        // The path is driven by the frames' source time, not the wall clock, so the
        // same frame is seen from the same place in every run and replay.
        const double t = fset->source_time_s - first_source_time;
        InFlight f;
        f.frame_seq = fset->seq;
        f.capture_time_ns = fset->capture_time_ns;
        f.sent_s = MonotonicSeconds();
        if (light) f.hull = hull;
        Rigid3d world_from_eye = orbit.WorldFromEye(t);
        if (view_source == "file") world_from_eye = track.At(t);
        if (view_source == "topic" && tracked) world_from_eye = *tracked;
        f.view = NovelView::FromFov(width, height, hfov_deg * M_PI / 180.0, world_from_eye);
        ++pose_seq;
        pose_writer.Write(ViewToMsg(f.view, pose_seq, fset->seq, NowNs()));
        in_flight[pose_seq] = std::move(f);
        last_requested = fset->seq;
      }

      // Composite every pose whose tiles are all in; give up on stale ones.
      for (auto it = in_flight.begin(); it != in_flight.end();) {
        InFlight& f = it->second;
        if (int(f.tiles.size()) < tiles) {
          if (MonotonicSeconds() - f.sent_s > tile_timeout) {
            spdlog::warn("pose {} (frame {}): {} of {} tiles after {:.1f} s; dropped", it->first, f.frame_seq,
                         f.tiles.size(), tiles, tile_timeout);
            reporter.Dropped();
            it = in_flight.erase(it);
          } else {
            ++it;
          }
          continue;
        }
        StageTimer st(reporter, "composite");
        cv::Mat depth(height, width, CV_32FC1, cv::Scalar(kNoDepth));
        cv::Mat colour(height, width, CV_8UC3, cv::Scalar(0, 0, 0));
        for (const auto& [idx, t] : f.tiles) {
          t.depth.copyTo(depth(t.rect));
          t.colour.copyTo(colour(t.rect));
        }
        hull_fraction_sum += double(cv::countNonZero(depth < std::numeric_limits<float>::infinity())) /
                             double(depth.total());
        std::vector<VirtualSphere> spheres;
        for (const auto& [id, per] : states) {
          // The state stepped against this frameset, else the newest before it.
          auto s = per.upper_bound(f.frame_seq);
          if (s == per.begin()) continue;
          --s;
          const auto& m = s->second;
          spheres.push_back({FromMsg(m.position), m.radius, bool(m.colliding)});
          if (m.colliding) ++collisions_drawn;
        }
        std::vector<VirtualMeshDraw> draws;
        for (const auto& [id, per] : meshes) {
          auto s = per.upper_bound(f.frame_seq);
          if (s == per.begin()) continue;
          --s;
          draws.push_back(s->second.draw);
          if (s->second.kind == hullpipe_msg_MESH_KIND_PART && s->second.clearance >= 0) {
            auto [mc, fresh] = min_clearance.try_emplace(id, s->second.clearance);
            if (!fresh) mc->second = std::min(mc->second, s->second.clearance);
            const auto& c = s->second.draw.colliding;
            if (std::find(c.begin(), c.end(), 1) != c.end()) ++part_collisions[id];
          }
        }
        meshes_drawn += draws.size();
        cv::Mat composited_depth;
        cv::Mat frame = Composite(f.view, depth, colour, spheres, comp, &composited_depth, draws);
        if (light) {
          StageTimer lt(reporter, "light");
          const ShadowMap shadow = RenderShadowMap(*light, orbit.up.normalized(), f.hull.get(), spheres, draws);
          ApplyLighting(f.view, composited_depth, depth, *light, shadow, &frame);
          ++lit_frames;
        }
        if (!video.isOpened()) {
          video.open(video_path, cv::VideoWriter::fourcc('m', 'p', '4', 'v'), video_fps, frame.size());
          if (!video.isOpened()) spdlog::warn("cannot open {} for writing; no video", video_path);
        }
        if (video.isOpened()) video.write(frame);
        const uint64_t composited = reporter.frames_out() + 1;
        if (png_every > 0 && composited % uint64_t(png_every) == 1 % uint64_t(png_every))
          cv::imwrite((fs::path(out_dir) / cv::format("frame_%05llu.png", (unsigned long long)f.frame_seq)).string(),
                      frame);
        if (show) {
          try {
            cv::imshow("hullpipe", frame);
            cv::waitKey(1);
          } catch (const cv::Exception& e) {
            spdlog::warn("cannot open a window ({}); continuing without", e.what());
            show = false;
          }
        }
        reporter.FrameOut(f.capture_time_ns);
        composited_last_round = true;
        last_composited = std::max(last_composited, f.frame_seq);
        // Older poses still waiting are superseded by this one.
        for (auto older = in_flight.begin(); older != it;) {
          reporter.Dropped();
          older = in_flight.erase(older);
        }
        it = in_flight.erase(it);
        if (max_frames > 0 && int64_t(last_composited) >= max_frames) done = true;
      }

      const double now = MonotonicSeconds();
      // A recon node that stops reporting (NodeStats every 0.5 s) is noticed
      // within a second; its tile comes from the lowest live recon node meanwhile.
      for (const auto& [rn, heard] : recon_heard) {
        const bool silent = now - heard > 1.0;
        if (silent != recon_silent[rn]) {
          recon_silent[rn] = silent;
          if (silent) {
            ++recon_outages[rn];
            spdlog::warn("{} silent for 1.0 s: its tile now comes from another recon node", rn);
          } else {
            spdlog::info("{} is back", rn);
          }
        }
      }
      // The input ended: capture said so and everything it sent is composited
      // (0.5 s for the last samples to land), or nothing came for idle_timeout.
      if (capture_done && in_flight.empty() && !assembler.NewestComplete() && now - capture_done_s > 0.5) {
        spdlog::info("input ended; all framesets handled");
        done = true;
      }
      if (any_frame && now - last_new_frame_s > idle_timeout && in_flight.empty()) {
        spdlog::info("no new frameset for {:.1f} s: input ended", idle_timeout);
        done = true;
      }
      if (now - last_progress_s >= 1.0) {
        last_progress_s = now;
        spdlog::info("frame {} | composited {} | {:.1f} fps | latency p50 {:.0f} ms p95 {:.0f} ms | dropped {}",
                     last_composited, reporter.frames_out(), reporter.fps(), reporter.latency_ms().Percentile(50),
                     reporter.latency_ms().Percentile(95), reporter.dropped());
      }
      reporter.SetRejected(rejected + input.rejected());
      reporter.Publish();
    }
    video.release();

    // Collect a last round of NodeStats (periodic reports are at most 0.5 s old).
    const double until = MonotonicSeconds() + 0.7;
    while (MonotonicSeconds() < until) {
      ws.Wait(0.05);
      take_stats();
    }

    std::vector<NodeRow> rows;
    for (const auto& [name, m] : node_stats) {
      if (name == "render") continue;
      rows.push_back({name, m.fps, m.latency_ms_p50, m.latency_ms_p95, m.frames_in, m.frames_out, m.dropped,
                      m.rejected, node_stages[name]});
    }
    NodeRow self{"render", reporter.fps(), reporter.latency_ms().Percentile(50), reporter.latency_ms().Percentile(95),
                 reporter.frames_in(), reporter.frames_out(), reporter.dropped(), rejected + input.rejected(),
                 nlohmann::json::object()};
    for (const auto& [n, s] : reporter.stages()) self.stages[n] = {{"ms_mean", s.Mean()}, {"ms_p95", s.Percentile(95)}};
    rows.push_back(self);

    nlohmann::json j;
    j["view"] = {{"width", width}, {"height", height}, {"tiles", tiles}};
    j["frames_composited"] = reporter.frames_out();
    j["last_frame_seq"] = last_composited;
    j["collision_frames_drawn"] = collisions_drawn;
    j["collision_reports_with_points"] = collision_reports;
    j["meshes_drawn"] = meshes_drawn;  // cloth, particle sets and payload parts, summed over frames
    j["lit_frames"] = lit_frames;      // frames with the scene's light and shadows
    j["recon_outages"] = recon_outages;  // times each recon node fell silent
    j["hull_pixel_fraction_mean"] = reporter.frames_out() ? hull_fraction_sum / double(reporter.frames_out()) : 0.0;
    j["video"] = video_path;
    for (const auto& [id, c] : min_clearance)
      j["payload"][std::to_string(id)] = {{"min_clearance_mm", c * 1e3}, {"frames_colliding", part_collisions[id]}};
    for (const auto& r : rows)
      j["nodes"][r.name] = {{"fps", r.fps},          {"latency_ms_p50", r.p50}, {"latency_ms_p95", r.p95},
                            {"frames_in", r.in},     {"frames_out", r.out},     {"dropped", r.dropped},
                            {"rejected", r.rejected}, {"stages_ms", r.stages}};
    std::ofstream((fs::path(out_dir) / "stats.json").string()) << j.dump(2) << "\n";

    std::printf("\n%-10s %8s %14s %14s %10s %10s %8s %8s\n", "node", "fps", "latency p50 ms", "latency p95 ms",
                "frames in", "frames out", "dropped", "rejected");
    for (const auto& r : rows)
      std::printf("%-10s %8.1f %14.1f %14.1f %10llu %10llu %8llu %8llu\n", r.name.c_str(), r.fps, r.p50, r.p95,
                  (unsigned long long)r.in, (unsigned long long)r.out, (unsigned long long)r.dropped,
                  (unsigned long long)r.rejected);
    std::printf("\nvideo: %s\nstats: %s\n", video_path.c_str(), (fs::path(out_dir) / "stats.json").c_str());
    std::fflush(stdout);
    reporter.Publish(true);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
