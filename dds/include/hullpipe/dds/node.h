// What every hullpipe node shares: the common command-line flags, logging, the
// participant, and the NodeStats reporter.
#pragma once

#include <map>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "hullpipe/dds/dds.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/util/latency_stats.h"

namespace hullpipe::dds {

/// Flags every node takes.
struct CommonOptions {
  uint32_t domain = 0;       ///< DDS domain id (tests use a unique one each).
  std::string dds_config;    ///< Cyclone XML config file (sets CYCLONEDDS_URI).
  std::string log_level = "info";
};

/// Adds --domain, --dds-config and --log-level to a CLI11 app.
void AddCommonOptions(CLI::App& app, CommonOptions& options);

/// Sets up logging (one line per message, "[node] ..."), exports CYCLONEDDS_URI
/// if --dds-config was given, installs the SIGINT/SIGTERM stop handler and
/// creates the participant.
std::unique_ptr<Participant> StartNode(const std::string& node_name, const CommonOptions& options);

/// Counts a node's work and publishes NodeStats about twice a second and at exit.
class NodeReporter {
 public:
  NodeReporter(const Participant& participant, std::string node_name);
  ~NodeReporter();
  void FrameIn(uint64_t n = 1) { frames_in_ += n; }
  /// One output published for a frameset captured at capture_time_ns.
  void FrameOut(int64_t capture_time_ns);
  void Dropped(uint64_t n = 1) { dropped_ += n; }
  void SetDropped(uint64_t n) { dropped_ = n; }
  void Rejected(uint64_t n = 1) { rejected_ += n; }
  void SetRejected(uint64_t n) { rejected_ = n; }
  /// Records a stage's duration in milliseconds.
  void Stage(const std::string& name, double ms);
  /// Publishes if 0.5 s passed since the last report (or always when final).
  void Publish(bool final_report = false);
  uint64_t frames_in() const { return frames_in_; }
  uint64_t frames_out() const { return frames_out_; }
  uint64_t dropped() const { return dropped_; }
  uint64_t rejected() const { return rejected_; }
  double fps() const;
  const SampleStats& latency_ms() const { return latency_; }
  const std::map<std::string, SampleStats>& stages() const { return stages_; }

 private:
  Writer<hullpipe_msg_NodeStats> writer_;
  std::string name_;
  uint64_t frames_in_ = 0, frames_out_ = 0, dropped_ = 0, rejected_ = 0;
  double first_out_s_ = -1, last_out_s_ = -1;
  double last_publish_s_ = 0;
  bool final_sent_ = false;
  SampleStats latency_{20000};
  std::map<std::string, SampleStats> stages_;
};

/// RAII timer: adds the elapsed milliseconds to a reporter stage on destruction.
class StageTimer {
 public:
  StageTimer(NodeReporter& r, std::string name);
  ~StageTimer();
  double ElapsedMs() const;

 private:
  NodeReporter& reporter_;
  std::string name_;
  double start_;
};

}  // namespace hullpipe::dds
