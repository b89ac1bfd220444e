// recon_node: renders its tile of the novel view's visual hull (paper §3.3).
// When render_node's ViewPose names a frameset and all n cameras' maps of it are in,
// it plane-sweeps its tile (CPU or GL backend), textures it from the camera images
// and publishes a HullView. Latest wins: framesets older than the one asked for are
// dropped and counted; nothing queues without bound. Fail-over: when a peer recon
// node falls silent (no NodeStats for --failover s), the lowest live tile's node
// renders the orphaned tile too, until the peer is heard again.
#include <deque>
#include <optional>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/frameset_input.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/reconstruction/frameset.h"
#include "hullpipe/gl/backend.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/texture.h"

using namespace hullpipe;
using namespace hullpipe::dds;

int main(int argc, char** argv) {
  CLI::App app{"hullpipe recon_node: object-pixel maps + ViewPose -> HullView tile"};
  CommonOptions common;
  AddCommonOptions(app, common);
  std::string tile_spec = "0/1";
  std::string backend_name = "auto";
  PlaneSweepOptions sweep;
  int threads = 1;
  int refine = 6;
  int visibility_width = 80;
  std::string out_of_view = "unknown";
  double pose_timeout = 1.0, failover = 1.2;
  app.add_option("--tile", tile_spec, "This node's tile i/N of the view (horizontal bands)")->capture_default_str();
  app.add_option("--backend", backend_name, "Sweep backend: cpu|gl|auto")
      ->check(CLI::IsMember({"cpu", "gl", "auto"}))->capture_default_str();
  app.add_option("--planes", sweep.num_planes, "Sweep planes")->capture_default_str();
  app.add_option("--threads", threads, "CPU sweep threads")->capture_default_str();
  app.add_option("--refine", refine, "Depth refinement bisections after the sweep (0: the paper's plane depth)")
      ->check(CLI::Range(0, 30))->capture_default_str();
  app.add_option("--visibility-width", visibility_width,
                 "Width of each camera's hull depth map for the texture visibility test (0: no test)")
      ->check(CLI::Range(0, 4096))->capture_default_str();
  app.add_option("--out-of-view", out_of_view,
                 "A camera that cannot see a point: unknown (does not vote) or outside (vetoes, as the paper)")
      ->check(CLI::IsMember({"unknown", "outside"}))->capture_default_str();
  app.add_option("--failover", failover,
                 "A peer recon node silent (no NodeStats) this many s: the lowest live tile renders its tile too")
      ->capture_default_str();
  app.add_option("--pose-timeout", pose_timeout, "Drop a pose whose frameset has not arrived after this many s")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  int tile_i = 0, tile_n = 1;
  if (std::sscanf(tile_spec.c_str(), "%d/%d", &tile_i, &tile_n) != 2 || tile_n < 1 || tile_i < 0 ||
      tile_i >= tile_n) {
    std::fprintf(stderr, "--tile must be i/N with 0 <= i < N\n");
    return 2;
  }
  const std::string name = "recon" + std::to_string(tile_i);
  try {
    sweep.Check();
    auto participant = StartNode(name, common);
    std::unique_ptr<gl::SweepBackend> backend = gl::MakeSweepBackend(backend_name, threads, refine);
    VolumeQueryOptions query_options;
    query_options.out_of_view = out_of_view == "outside" ? OutOfView::kOutside : OutOfView::kUnknown;
    spdlog::info("tile {}/{}, backend {}", tile_i, tile_n, backend->Name());

    WaitSet ws(*participant);
    FramesetInput input(*participant, ws, 8, /*with_images=*/true);
    FramesetAssembler& assembler = input.assembler();
    Reader<hullpipe_msg_ViewPose> pose_reader(*participant);
    ws.Attach(pose_reader);
    Writer<hullpipe_msg_HullView> tile_writer(*participant);
    NodeReporter reporter(*participant, name);
    // Fail-over: every recon node publishes NodeStats twice a second; a peer
    // silent for `failover` s (or that reported its end) has its tile rendered by
    // the lowest live tile's node until it is heard again.
    Reader<hullpipe_msg_NodeStats> peer_stats(*participant);
    const double started_s = MonotonicSeconds();
    std::vector<double> peer_seen(size_t(tile_n), started_s);
    std::vector<bool> adopted(size_t(tile_n), false);
    auto my_tiles = [&] {
      const double now = MonotonicSeconds();
      std::vector<bool> alive(static_cast<size_t>(tile_n));
      for (int k = 0; k < tile_n; ++k) alive[size_t(k)] = k == tile_i || now - peer_seen[size_t(k)] < failover;
      int lowest = tile_i;
      for (int k = 0; k < tile_n; ++k)
        if (alive[size_t(k)]) {
          lowest = k;
          break;
        }
      std::vector<int> tiles = {tile_i};
      for (int k = 0; k < tile_n; ++k) {
        const bool adopt = !alive[size_t(k)] && lowest == tile_i;
        if (adopt != adopted[size_t(k)]) {
          adopted[size_t(k)] = adopt;
          if (adopt) spdlog::warn("recon{} silent for {:.1f} s: rendering tile {} too", k, failover, k);
          else spdlog::info("tile {} back with recon{} (or adopted by another)", k, k);
        }
        if (adopt) tiles.push_back(k);
      }
      return tiles;
    };

    struct PendingPose {
      hullpipe_msg_ViewPose msg;
      NovelView view;
      double received_s;
    };
    std::deque<PendingPose> poses;
    uint64_t rejected_msgs = 0, poses_dropped = 0;
    auto reject = [&](const std::string& why) {
      ++rejected_msgs;
      spdlog::warn("rejected: {}", why);
    };

    while (!StopRequested()) {
      ws.Wait(0.1);
      input.Poll();
      peer_stats.TakeEach([&](const hullpipe_msg_NodeStats& m, const dds_sample_info_t&) {
        int k = -1;
        if (!m.node_name || std::sscanf(m.node_name, "recon%d", &k) != 1 || k < 0 || k >= tile_n || k == tile_i) return;
        peer_seen[size_t(k)] = m.final_report ? -1e9 : MonotonicSeconds();
      });
      pose_reader.TakeEach([&](const hullpipe_msg_ViewPose& m, const dds_sample_info_t&) {
        try {
          poses.push_back({m, ViewFromMsg(m), MonotonicSeconds()});
        } catch (const MessageError& e) {
          reject(e.what());
        }
      });
      // Serve the newest pose whose frameset is ready; older poses are superseded.
      while (!poses.empty()) {
        const PendingPose& p = poses.front();
        const uint64_t want = p.msg.frame_seq;
        const bool newer_pose_waiting = poses.size() > 1;
        const bool ready = want == 0 ? assembler.NewestComplete().has_value() : assembler.IsComplete(want);
        if (!ready) {
          const bool gone = want != 0 && assembler.IsGone(want);
          if (gone || newer_pose_waiting || MonotonicSeconds() - p.received_s > pose_timeout) {
            ++poses_dropped;
            poses.pop_front();
            continue;
          }
          break;
        }
        if (newer_pose_waiting) {
          const PendingPose& next = poses[1];
          const uint64_t next_want = next.msg.frame_seq;
          if (next_want == 0 || assembler.IsComplete(next_want)) {
            ++poses_dropped;
            poses.pop_front();
            continue;
          }
        }
        std::optional<Frameset> fs = want == 0 ? assembler.TakeNewest() : assembler.Take(want);
        const PendingPose pose = p;
        poses.pop_front();
        if (!fs) continue;
        reporter.FrameIn();
        const double t0 = MonotonicSeconds();
        const VolumeQuery vq(fs->maps, assembler.workspace(), query_options);  // includes the hull box
        const std::vector<double> depths = SweepPlaneDepths(vq, pose.view, sweep);
        reporter.Stage("hull_box", (MonotonicSeconds() - t0) * 1e3);
        std::optional<HullVisibility> vis;
        if (visibility_width > 0) {
          StageTimer st(reporter, "visibility");
          std::vector<Camera> cams;
          for (const auto& im : fs->images) cams.push_back(im.camera);
          PlaneSweepOptions vis_sweep = sweep;
          vis_sweep.num_planes = std::min(sweep.num_planes, 48);
          vis = ComputeHullVisibility(vq, cams, visibility_width, vis_sweep, refine, threads);
        }
        for (const int t : my_tiles()) {
          const double tt0 = MonotonicSeconds();
          const cv::Rect rect = TileRect(t, tile_n, pose.view.width, pose.view.height);
          HullTile tile;
          {
            StageTimer st(reporter, "sweep");
            tile.depth = backend->Sweep(vq, pose.view, depths, rect);
          }
          {
            StageTimer st(reporter, "texture");
            tile.colour = TextureHull(tile.depth, rect, pose.view, fs->images, {}, vis ? &*vis : nullptr);
          }
          tile.rect = rect;
          tile.node_id = uint32_t(tile_i);
          tile.tile_index = uint32_t(t);
          tile.tile_count = uint32_t(tile_n);
          tile.pose_seq = pose.msg.pose_seq;
          tile.frame_seq = fs->seq;
          tile.capture_time_ns = fs->capture_time_ns;
          tile.render_ms = (MonotonicSeconds() - (t == tile_i ? t0 : tt0)) * 1e3;
          tile_writer.Write(MakeHullViewMessage(tile, uint32_t(depths.size())).msg);
        }
        reporter.FrameOut(fs->capture_time_ns);
      }
      reporter.SetDropped(input.dropped() + poses_dropped);
      reporter.SetRejected(input.rejected() + rejected_msgs);
      reporter.Publish();
    }
    reporter.Publish(true);
    spdlog::info("stopped: {} tiles out, {} dropped, {} rejected", reporter.frames_out(), reporter.dropped(),
                 reporter.rejected());
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
