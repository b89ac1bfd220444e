// What a node counts about its own work and reports as NodeStats (twice a
// second and at exit): frames in and out, drops, rejections, output rate,
// capture-to-output latency and per-stage times. DDS-free; dds/node.h publishes it.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "hullpipe/pipeline/clock.h"
#include "hullpipe/pipeline/node_stats.h"
#include "hullpipe/util/latency_stats.h"

namespace hullpipe {

class NodeCounters {
 public:
  /// The host name (NodeStatsSample::host) is this machine's (gethostname).
  explicit NodeCounters(const Clock& clock);
  void FrameIn(uint64_t n = 1) { frames_in_ += n; }
  /// One output for a frameset captured at capture_time_ns (wall clock; <= 0:
  /// unknown, no latency sample).
  void FrameOut(int64_t capture_time_ns);
  void Dropped(uint64_t n = 1) { dropped_ += n; }
  void SetDropped(uint64_t n) { dropped_ = n; }
  void Rejected(uint64_t n = 1) { rejected_ += n; }
  void SetRejected(uint64_t n) { rejected_ = n; }
  /// How the node's frameset assembler paired its cameras
  /// (FramesetAssembler::SkewReports and dropped_for_skew).
  void SetAssembly(std::vector<CameraSkewReport> cameras, uint64_t dropped_for_skew) {
    cameras_ = std::move(cameras);
    dropped_for_skew_ = dropped_for_skew;
  }
  /// What computes this node's work (NodeStatsSample::backend).
  void SetBackend(std::string backend) { backend_ = std::move(backend); }
  /// Adds one duration (milliseconds) to a stage (docs/latency.md). Negative
  /// durations (a stamp from another host's clock running ahead) are kept as
  /// they are: the budget shows the clocks' disagreement rather than hiding it.
  void Stage(const std::string& name, double ms) {
    auto it = stages_.find(name);
    if (it == stages_.end()) it = stages_.emplace(name, SampleStats(kStageSamples)).first;
    it->second.Add(ms);
  }
  /// Adds the time from a wall-clock stamp (CLOCK_REALTIME ns, maybe another
  /// host's: a DDS source timestamp, a sample's arrival) to now on this node's
  /// clock, in milliseconds, to a stage; a stamp of 0 (unknown) adds nothing.
  void StageSince(const std::string& name, int64_t since_wall_ns) {
    if (since_wall_ns != 0) Stage(name, double(clock_.WallNs() - since_wall_ns) * 1e-6);
  }
  /// Samples kept per stage (a ring: the most recent ones).
  static constexpr size_t kStageSamples = 20000;
  uint64_t frames_in() const { return frames_in_; }
  uint64_t frames_out() const { return frames_out_; }
  uint64_t dropped() const { return dropped_; }
  uint64_t rejected() const { return rejected_; }
  /// Outputs per second between the first and the last output (0 before two).
  double fps() const;
  const SampleStats& latency_ms() const { return latency_; }
  const std::map<std::string, SampleStats>& stages() const { return stages_; }
  const Clock& clock() const { return clock_; }
  /// This machine's host name (gethostname; empty if it failed).
  const std::string& host() const { return host_; }
  /// The report of this node under `name`.
  NodeStatsSample Snapshot(const std::string& name, bool final_report) const;

 private:
  const Clock& clock_;
  uint64_t frames_in_ = 0, frames_out_ = 0, dropped_ = 0, rejected_ = 0;
  double first_out_s_ = -1, last_out_s_ = -1;
  SampleStats latency_{20000};
  std::map<std::string, SampleStats> stages_;
  std::vector<CameraSkewReport> cameras_;
  uint64_t dropped_for_skew_ = 0;
  std::string backend_;
  std::string host_;
};

/// RAII: adds the elapsed milliseconds (on the counters' clock) to a stage.
class StageTimer {
 public:
  StageTimer(NodeCounters& counters, std::string name)
      : counters_(counters), name_(std::move(name)), start_(counters.clock().Now()) {}
  ~StageTimer() { counters_.Stage(name_, ElapsedMs()); }
  StageTimer(const StageTimer&) = delete;
  StageTimer& operator=(const StageTimer&) = delete;
  double ElapsedMs() const { return (counters_.clock().Now() - start_) * 1e3; }

 private:
  NodeCounters& counters_;
  std::string name_;
  double start_;
};

}  // namespace hullpipe
