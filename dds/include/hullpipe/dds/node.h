// What every hullpipe node shares: the common command-line flags, logging, the
// participant, and the NodeStats reporter.
#pragma once

#include <map>
#include <memory>
#include <string>

#include "hullpipe/dds/dds.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/pipeline/node_counters.h"

namespace CLI {
class App;  // CLI11: only the files that register flags compile it (docs/benchmarks.md, "Build")
}  // namespace CLI

namespace hullpipe::dds {

/// Flags every node takes.
struct CommonOptions {
  uint32_t domain = 0;       ///< DDS domain id (tests use a unique one each).
  std::string dds_config;    ///< Cyclone XML config file (sets CYCLONEDDS_URI).
  std::string log_level = "info";
  /// The run this node belongs to (docs/reliability.md, "run id"): its NodeStats
  /// carry it; render_node and recon_node ignore samples of another run. 0: none
  /// given (its reports are taken by any run; render_node then picks its own).
  uint64_t run_id = 0;
};

/// Adds --domain, --dds-config and --log-level to a CLI11 app.
void AddCommonOptions(CLI::App& app, CommonOptions& options);
/// Adds the nodes' --run-id (1 to 16 hex digits, not zero) into options.run_id.
void AddRunIdOption(CLI::App& app, CommonOptions& options);
/// The opening every executable on the domain shares: its log on stderr as
/// `log_name` (stdout carries only what a user asked for), its command line
/// kept for its NodeStats (util/logging.h), and the common flags on `app`
/// (AddCommonOptions; AddRunIdOption where `with_run_id`: the pipeline's nodes).
void OpenCommandLine(int argc, char** argv, const std::string& log_name, CLI::App& app, CommonOptions& options,
                     bool with_run_id = false);

/// Sets up logging (one line per message, "[node] ..."), keeps freed memory
/// for the next frameset (util/memory.h KeepFreedMemory), exports
/// CYCLONEDDS_URI if --dds-config was given, installs the SIGINT/SIGTERM stop
/// handler and creates the participant.
std::unique_ptr<Participant> StartNode(const std::string& node_name, const CommonOptions& options);

/// Publishes a node's counters (nodes/node_counters.h) as NodeStats about twice
/// a second and, once, a final report (at the latest when destroyed).
class NodeReporter {
 public:
  NodeReporter(const Participant& participant, std::string node_name, const NodeCounters& counters,
               uint64_t run_id = 0);
  ~NodeReporter();
  NodeReporter(const NodeReporter&) = delete;
  NodeReporter& operator=(const NodeReporter&) = delete;
  /// Publishes if 0.5 s passed since the last report (or always when final).
  void Publish(bool final_report = false);
  const std::string& name() const { return name_; }

 private:
  Writer<hullpipe_msg_NodeStats> writer_;
  std::string name_;
  const NodeCounters& counters_;
  uint64_t run_id_ = 0;
  double last_publish_s_ = -1e9;
  bool final_sent_ = false;
};

}  // namespace hullpipe::dds
