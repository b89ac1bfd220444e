#include "hullpipe/nodes/recon_controller.h"

#include <algorithm>
#include <cstdio>
#include <optional>
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "hullpipe/reconstruction/texture.h"
#include "hullpipe/util/parallel.h"

namespace hullpipe::nodes {

void ReconOptions::ParseTile(const std::string& spec) {
  int i = 0, n = 0;
  char tail = 0;
  if (std::sscanf(spec.c_str(), "%d/%d%c", &i, &n, &tail) != 2 || n < 1 || n > 64 || i < 0 || i >= n)
    throw std::invalid_argument("--tile must be i/N with 0 <= i < N <= 64");
  tile = i;
  tile_count = n;
}

void ReconOptions::Check() const {
  auto bad = [](const std::string& what) { throw std::invalid_argument(what); };
  if (tile_count < 1 || tile_count > 64 || tile < 0 || tile >= tile_count)
    bad("--tile must be i/N with 0 <= i < N <= 64");
  sweep.Check();
  if (threads < 0 || threads > 256) bad("--threads must be 0..256 (0: what the host gives each recon node)");
  if (host_cores < 0 || host_cores > 4096) bad("host cores must be 0..4096");
  if (refine < 0 || refine > 30) bad("--refine must be 0..30");
  if (visibility_width < 0 || visibility_width > 4096) bad("--visibility-width must be 0..4096");
  if (!(pose_timeout > 0 && pose_timeout <= 3600)) bad("--pose-timeout must be in (0, 3600] s");
  if (!(failover > 0 && failover <= 3600)) bad("--failover must be in (0, 3600] s");
}

ReconController::ReconController(ReconOptions options, const Clock& clock, FramesetAssembler& assembler,
                                 SweepBackend& backend, ReconSink& sink)
    : o_(std::move(options)),
      clock_(clock),
      assembler_(assembler),
      backend_(backend),
      sink_(sink),
      counters_(clock),
      peers_((o_.Check(), o_.failover)),
      runs_(o_.run_id),
      adopted_(size_t(o_.tile_count), false) {
  query_options_.out_of_view = o_.out_of_view;
  const std::string gl = backend_.GlSummary();
  counters_.SetBackend(gl.empty() ? backend_.Name() : backend_.Name() + " | " + gl);
  // Every peer counts as heard at the start: none is adopted before it had
  // `failover` s to report.
  for (int k = 0; k < o_.tile_count; ++k)
    if (k != o_.tile) peers_.Expect("recon" + std::to_string(k), clock_.Now());
}

void ReconController::OnPose(const NovelView& view, uint64_t pose_seq, uint64_t frame_seq, uint64_t run_id) {
  if (!runs_.Accept(run_id, "ViewPose", /*take_unset=*/false)) return;
  poses_.push_back({view, pose_seq, frame_seq, clock_.Now(), run_id});
}

void ReconController::OnNodeStats(const std::string& name, bool final_report, uint64_t run_id,
                                  const std::string& host) {
  if (!runs_.Accept(run_id, "NodeStats", /*take_unset=*/true, name)) return;
  int k = -1;
  char tail = 0;
  if (std::sscanf(name.c_str(), "recon%d%c", &k, &tail) != 1 || k < 0 || k >= o_.tile_count || k == o_.tile) return;
  if (name != "recon" + std::to_string(k)) return;  // "recon01", "recon+1": not a peer's name (unbounded keys)
  peers_.Heard(name, clock_.Now(), final_report);
  peer_hosts_[name] = host;  // at most tile_count - 1 keys
}

int ReconController::ThreadsNow() {
  if (o_.threads > 0) return o_.threads;
  const int cores = ThreadsOrCores(o_.host_cores);
  const double now = clock_.Now();
  int sharing = 1;
  for (const auto& [peer, host] : peer_hosts_)
    if (!host.empty() && host == counters_.host() && peers_.Alive(peer, now)) ++sharing;
  const int threads = std::clamp(cores / sharing, 1, 256);
  if (threads != threads_said_) {
    spdlog::info("{} CPU thread(s): {} core(s) shared by {} recon node(s) on this host", threads, cores, sharing);
    threads_said_ = threads;
  }
  return threads;
}

void ReconController::Reject(const std::string& why) {
  ++rejected_;
  reject_log_.Log(why, clock_.Now());
}

std::vector<int> ReconController::MyTiles() {
  const double now = clock_.Now();
  std::vector<bool> alive(size_t(o_.tile_count));
  for (int k = 0; k < o_.tile_count; ++k)
    alive[size_t(k)] = k == o_.tile || peers_.Alive("recon" + std::to_string(k), now);
  const int lowest = int(std::find(alive.begin(), alive.end(), true) - alive.begin());
  std::vector<int> tiles = {o_.tile};
  for (int k = 0; k < o_.tile_count; ++k) {
    const bool adopt = !alive[size_t(k)] && lowest == o_.tile;
    if (adopt != adopted_[size_t(k)]) {
      adopted_[size_t(k)] = adopt;
      if (adopt)
        spdlog::warn("recon{} silent for {:.1f} s: rendering tile {} too", k, o_.failover, k);
      else
        spdlog::info("tile {} back with recon{} (or adopted by another)", k, k);
    }
    if (adopt) tiles.push_back(k);
  }
  return tiles;
}

int ReconController::Step() {
  int published = 0;
  // Serve the newest pose whose frameset is ready; older poses are superseded.
  while (!poses_.empty()) {
    const PendingPose& p = poses_.front();
    const uint64_t want = p.frame_seq;
    // The frameset rendered last is still here for another view of it.
    auto served = [&](uint64_t seq) { return seq != 0 && last_.frameset && seq == last_.seq; };
    // The first later pose that names another frameset: the poses between name
    // this one (the other eye of a stereo pair) and supersede nothing.
    size_t next = 1;
    while (want != 0 && next < poses_.size() && poses_[next].frame_seq == want) ++next;
    const bool newer_pose_waiting = poses_.size() > next;
    const bool ready =
        served(want) || (want == 0 ? assembler_.NewestComplete().has_value() : assembler_.IsComplete(want));
    if (!ready) {
      const bool gone = want != 0 && assembler_.IsGone(want);
      if (gone || newer_pose_waiting || clock_.Now() - p.received_s > o_.pose_timeout) {
        ++poses_dropped_;
        poses_.pop_front();
        continue;
      }
      break;
    }
    if (newer_pose_waiting) {
      const uint64_t next_want = poses_[next].frame_seq;
      if (next_want == 0 || served(next_want) || assembler_.IsComplete(next_want)) {
        ++poses_dropped_;
        poses_.pop_front();
        continue;
      }
    }
    const PendingPose pose = p;
    poses_.pop_front();
    if (served(want)) {
      published += Render(pose, last_.frameset, /*again=*/true);
      continue;
    }
    std::optional<Frameset> fs = want == 0 ? assembler_.TakeNewest() : assembler_.Take(want);
    if (!fs) continue;
    last_ = Served{};  // the backend is about to begin another frameset
    published += Render(pose, std::make_shared<const Frameset>(std::move(*fs)), /*again=*/false);
  }
  counters_.SetDropped(assembler_.dropped() + poses_dropped_);
  counters_.SetAssembly(assembler_.SkewReports(), assembler_.dropped_for_skew());
  counters_.SetRejected(assembler_.rejected() + assembler_.calibrations_refused() + rejected_ + malformed_input_);
  return published;
}

int ReconController::Render(const PendingPose& pose, const std::shared_ptr<const Frameset>& frameset, bool again) {
  const Frameset& fs = *frameset;
  counters_.FrameIn();
  // The budget's recon stages (docs/latency.md): wait (the frameset's last
  // sample taken to this start: a pose naming it, or this node busy), hull_box,
  // upload, visibility, sweep, refine, texture, publish. A second view of the
  // frameset rendered last has only its own plane depths, sweep and texture.
  const int threads = ThreadsNow();
  backend_.set_threads(threads);
  query_options_.threads = threads;
  const double t0 = clock_.Now();
  const bool with_visibility = o_.visibility_width > 0;
  std::shared_ptr<const VolumeQuery> query = last_.query;
  if (!again) {
    counters_.StageSince("wait", fs.last_arrival_ns);
    query = std::make_shared<const VolumeQuery>(fs.maps, assembler_.workspace(), query_options_);  // the hull box
  }
  const VolumeQuery& vq = *query;
  const std::vector<double> depths = SweepPlaneDepths(vq, pose.view, o_.sweep);
  if (!again) {
    counters_.Stage("hull_box", (clock_.Now() - t0) * 1e3);
    {
      StageTimer st(counters_, "upload");
      backend_.BeginFrameset(vq, fs.images);
    }
    if (with_visibility) {
      StageTimer st(counters_, "visibility");
      std::vector<Camera> cams;
      for (const auto& im : fs.images) cams.push_back(im.camera);
      PlaneSweepOptions vis_sweep = o_.sweep;
      vis_sweep.num_planes = std::min(o_.sweep.num_planes, 48);
      backend_.ComputeVisibility(vq, cams, o_.visibility_width, vis_sweep);
    }
    last_ = Served{fs.seq, frameset, query};
  }
  int published = 0;
  spdlog::debug("frameset {}, pose {}: sweeping a {}x{} view, {} planes", fs.seq, pose.pose_seq, pose.view.width,
                pose.view.height, depths.size());
  for (const int t : MyTiles()) {
    const double tt0 = clock_.Now();
    const cv::Rect rect = TileRect(t, o_.tile_count, pose.view.width, pose.view.height);
    HullTile tile;
    SweepStats sweep_stats;
    TexturedTile swept = backend_.SweepTextured(vq, pose.view, depths, rect, fs.images, with_visibility, &sweep_stats);
    tile.depth = std::move(swept.depth);
    tile.colour = std::move(swept.colour);
    counters_.Stage("sweep", sweep_stats.sweep_ms);
    counters_.Stage("refine", sweep_stats.refine_ms);
    counters_.Stage("texture", swept.texture_ms);
    if (swept.refetched_images > 0)
      spdlog::debug("frameset {}, tile {}: {} image(s) uploaded whole for the texture pass", fs.seq, t,
                    swept.refetched_images);
    tile.rect = rect;
    tile.node_id = uint32_t(o_.tile);
    tile.tile_index = uint32_t(t);
    tile.tile_count = uint32_t(o_.tile_count);
    tile.pose_seq = pose.pose_seq;
    tile.frame_seq = fs.seq;
    tile.capture_time_ns = fs.capture_time_ns;
    tile.run_id = pose.run_id;
    tile.render_ms = (clock_.Now() - (t == o_.tile ? t0 : tt0)) * 1e3;
    StageTimer st(counters_, "publish");
    sink_.PublishTile(tile, uint32_t(depths.size()));
    ++published;
  }
  counters_.FrameOut(fs.capture_time_ns);
  return published;
}

}  // namespace hullpipe::nodes
