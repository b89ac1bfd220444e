// recon_node's run-time logic (paper §3.3): render_node's ViewPose names a
// frameset; when all n cameras' maps of it are in, the node plane-sweeps its tile
// of the view (CPU or GL backend), textures it from the camera images (with the
// visibility test) and publishes a HullView. Latest wins: a pose is superseded by
// a newer one whose frameset is ready, and dropped when its frameset is gone or
// does not come within pose_timeout; nothing queues without bound. Fail-over: a
// peer recon node silent for `failover` s (PeerLiveness) has its tile rendered by
// the lowest live tile's node until it is heard again. DDS-free; tests drive it
// with a FakeClock and the CPU backend.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "hullpipe/pipeline/clock.h"
#include "hullpipe/pipeline/messages.h"
#include "hullpipe/pipeline/node_counters.h"
#include "hullpipe/util/reject_log.h"
#include "hullpipe/nodes/peer_liveness.h"
#include "hullpipe/nodes/run_filter.h"
#include "hullpipe/reconstruction/frameset.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/sweep_backend.h"
#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe::nodes {

/// recon_node's settings (its flags).
struct ReconOptions {
  int tile = 0, tile_count = 1;  ///< This node's tile i of N horizontal bands.
  PlaneSweepOptions sweep;       ///< Planes and their placement (§3.3).
  /// CPU threads of the sweep, the visibility maps and the hull box search
  /// (1..256), or 0: what this host can give each recon node on it, its cores
  /// (host_cores) shared among this node and the live peers reporting the
  /// same host name, re-decided per frameset.
  int threads = 0;
  int host_cores = 0;            ///< Cores for threads = 0 (0: std::thread::hardware_concurrency()).
  int refine = 6;                ///< Depth refinement bisections (0..30; 0: the paper's plane depth).
  int visibility_width = 80;     ///< Width of each camera's hull depth map for the visibility test (0: none).
  OutOfView out_of_view = OutOfView::kUnknown;
  double pose_timeout = 1.0;     ///< Drop a pose whose frameset did not come within this many s.
  double failover = 1.2;         ///< A peer silent this many s has its tile adopted.
  uint64_t run_id = 0;           ///< This run (--run-id; 0: serve any run's poses). nodes/run_filter.h.
  /// Parses "i/N" (0 <= i < N <= 64) into tile, tile_count; std::invalid_argument otherwise.
  void ParseTile(const std::string& spec);
  /// Throws std::invalid_argument naming the flag out of range.
  void Check() const;
  /// "recon<i>", the name in NodeStats.
  std::string NodeName() const { return "recon" + std::to_string(tile); }
};

/// Where recon's tiles go (HullView messages).
class ReconSink {
 public:
  virtual ~ReconSink() = default;
  virtual void PublishTile(const HullTile& tile, uint32_t planes) = 0;
};

class ReconController {
 public:
  ReconController(ReconOptions options, const Clock& clock, FramesetAssembler& assembler,
                  SweepBackend& backend, ReconSink& sink);
  /// A ViewPose of run `run_id`: render frameset frame_seq (0: the newest
  /// complete) from `view`; its tile carries the run id back. A pose of another
  /// run is ignored (counted in runs().ignored(); one warning per run).
  void OnPose(const NovelView& view, uint64_t pose_seq, uint64_t frame_seq, uint64_t run_id = 0);
  /// A NodeStats sample of node `name` (peers are "recon<k>"; others ignored,
  /// as are reports of another run: a replayed peer must not seem alive).
  /// `host`: the peer's host name (NodeStats.host; recon peers on this node's
  /// host share its cores when threads is 0).
  void OnNodeStats(const std::string& name, bool final_report, uint64_t run_id = 0, const std::string& host = "");
  /// The CPU threads the next frameset gets (ReconOptions::threads).
  int ThreadsNow();
  /// A malformed sample the caller could not convert: counted, its line
  /// written as RejectLog bounds it.
  void Reject(const std::string& why);
  /// Input samples the caller could not decode before they reached the
  /// assembler (counted into this node's rejected, with the assembler's own).
  void SetMalformedInput(uint64_t n) { malformed_input_ = n; }
  /// Serves every pose that can be served now; returns the tiles published.
  /// A pose is superseded by a later one naming a newer frameset that is
  /// ready; poses naming the same frameset (a stereo pair's eyes) are each
  /// served, the second from the first's query, upload and visibility maps.
  /// Throws Interrupted (util/interrupt.h) when the backend's stop flag is set
  /// mid-render: the node is stopping, and the pose is dropped.
  int Step();
  /// The tiles this node renders now: its own, plus any it adopts.
  std::vector<int> MyTiles();

  NodeCounters& counters() { return counters_; }
  const NodeCounters& counters() const { return counters_; }
  uint64_t poses_dropped() const { return poses_dropped_; }
  const RunFilter& runs() const { return runs_; }
  uint64_t rejected() const { return rejected_; }

 private:
  struct PendingPose {
    NovelView view;
    uint64_t pose_seq = 0, frame_seq = 0;
    double received_s = 0;
    uint64_t run_id = 0;
  };
  // Renders `pose` from frameset *fs; again: *fs is the frameset rendered last
  // (last_), whose query, upload and visibility maps are reused.
  int Render(const PendingPose& pose, const std::shared_ptr<const Frameset>& fs, bool again);
  // The frameset rendered last and its volume query, kept while poses may still
  // name it: another view of the same frameset (the other eye of a stereo
  // pair) is swept against the same maps, hull box, upload and visibility maps
  // (the backend still holds them: no frameset has begun since).
  struct Served {
    uint64_t seq = 0;
    std::shared_ptr<const Frameset> frameset;
    std::shared_ptr<const VolumeQuery> query;
  };
  Served last_;

  ReconOptions o_;
  const Clock& clock_;
  RejectLog reject_log_;  // the rejected samples' warning lines, bounded
  FramesetAssembler& assembler_;
  SweepBackend& backend_;
  ReconSink& sink_;
  NodeCounters counters_;
  PeerLiveness peers_;
  RunFilter runs_;
  VolumeQueryOptions query_options_;
  std::vector<bool> adopted_;
  std::map<std::string, std::string> peer_hosts_;  // recon peer -> its host name
  int threads_said_ = -1;
  std::deque<PendingPose> poses_;
  uint64_t poses_dropped_ = 0, rejected_ = 0, malformed_input_ = 0;
};

}  // namespace hullpipe::nodes
