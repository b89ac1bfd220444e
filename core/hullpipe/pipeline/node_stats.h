// A node's report as it travels (NodeStats, idl/hullpipe.idl), DDS-free: the
// per-camera pairing report of a frameset assembler (reconstruction/frameset.h)
// and the node's counters and stage times (docs/latency.md).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace hullpipe {

/// Per camera: how well its samples found partners (NodeStats, stats.json).
struct CameraSkewReport {
  int camera_id = 0;
  double skew_ms_p50 = 0, skew_ms_p95 = 0, skew_ms_max = 0;  ///< |capture time - t_ref| over framesets taken.
  uint64_t frames = 0;         ///< Samples received.
  uint64_t unpartnered = 0;    ///< Samples that left the history without belonging to a complete frameset.
  /// Gaps of more than FramesetAssembler::kPausePeriods frame periods (and kPauseMinS) in its capture times.
  uint64_t pauses = 0;
  uint64_t restarts = 0;       ///< Its capture source restarted (a new writer, or frame numbers starting over).
  uint64_t clock_offsets = 0;  ///< Episodes of FramesetAssembler::kOffsetFramesets framesets in a row out of tolerance.
  double period_ms = 0;        ///< Measured frame period (median of recent capture-time steps); 0 until known.
};

/// One node's report as it travels (NodeStats), DDS-free.
struct NodeStatsSample {
  std::string name;
  double fps = 0;
  double latency_ms_p50 = 0, latency_ms_p95 = 0;
  uint64_t frames_in = 0, frames_out = 0, dropped = 0, rejected = 0;
  bool final_report = false;  ///< The node is stopping.
  /// One stage's durations (docs/latency.md names each stage and what it measures).
  struct Stage {
    double ms_mean = 0, ms_p50 = 0, ms_p95 = 0;
    uint64_t count = 0;  ///< Samples taken in all.
  };
  std::map<std::string, Stage> stages;
  uint64_t dropped_for_skew = 0;             ///< Framesets dropped for skew (assembling nodes).
  std::vector<CameraSkewReport> cameras;     ///< Per camera (assembling nodes; empty otherwise).
  std::string backend;  ///< "cpu", or the GL method and GlInfo::Summary() (empty: not reported).
  uint64_t run_id = 0;  ///< The node's --run-id (0: none given; docs/reliability.md, "run id").
  std::string host;     ///< The node's host name (empty: not reported): which stamps cross hosts.
};

}  // namespace hullpipe
