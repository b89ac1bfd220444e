#include "hullpipe/dds/node.h"

#include <cstdlib>
#include <filesystem>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/core/utils/logger.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/dds/node_stats_convert.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/util/cli_range.h"
#include "hullpipe/util/run_id.h"
#include "hullpipe/util/logging.h"
#include "hullpipe/util/memory.h"

namespace hullpipe::dds {

void AddCommonOptions(CLI::App& app, CommonOptions& o) {
  app.add_option("--domain", o.domain, "DDS domain id")->check(DomainIdRange())->capture_default_str();
  app.add_option("--dds-config", o.dds_config, "Cyclone DDS XML config file (sets CYCLONEDDS_URI)");
  // spdlog reads an unknown name as "off": a node that says nothing.
  app.add_option("--log-level", o.log_level, "trace|debug|info|warn|error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}))
      ->capture_default_str();
}

void OpenCommandLine(int argc, char** argv, const std::string& log_name, CLI::App& app, CommonOptions& options,
                     bool with_run_id) {
  LogToStderr(log_name);
  SetCommandLine(argc, argv);
  AddCommonOptions(app, options);
  if (with_run_id) AddRunIdOption(app, options);
}

void AddRunIdOption(CLI::App& app, CommonOptions& o) {
  app.add_option_function<std::string>(
         "--run-id",
         [&o](const std::string& text) { o.run_id = ParseRunId(text).value_or(0); },  // checked below
         "This run's id (hex; hullpipe_launch gives every node one): NodeStats carry it, and render_node and "
         "recon_node ignore samples of another run on the domain")
      ->check(RunIdValidator());
}



std::unique_ptr<Participant> StartNode(const std::string& node_name, const CommonOptions& o) {
  LogToStderr(node_name);
  spdlog::set_level(spdlog::level::from_str(o.log_level));
  // A frameset's freed blocks stay for the next (util/memory.h): no page
  // faults per frameset.
  KeepFreedMemory();
  // Nodes report bad input themselves, one line each; OpenCV's own log would
  // repeat it in another format.
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  if (!o.dds_config.empty()) {
    if (!std::filesystem::exists(o.dds_config))
      throw std::runtime_error("--dds-config " + o.dds_config + ": no such file");
    const std::string uri = "file://" + std::filesystem::absolute(o.dds_config).string();
    setenv("CYCLONEDDS_URI", uri.c_str(), 1);
  }
  InstallStopHandler();
  return std::make_unique<Participant>(o.domain);
}

NodeReporter::NodeReporter(const Participant& p, std::string name, const NodeCounters& counters,
                           uint64_t run_id)
    : writer_(p), name_(std::move(name)), counters_(counters), run_id_(run_id) {}

NodeReporter::~NodeReporter() {
  try {
    Publish(true);
  } catch (...) {
  }
}

void NodeReporter::Publish(bool final_report) {
  const double now = counters_.clock().Now();
  if (final_sent_ || (!final_report && now - last_publish_s_ < 0.5)) return;
  last_publish_s_ = now;
  NodeStatsSample s = counters_.Snapshot(name_, final_report);
  s.run_id = run_id_;
  writer_.Write(MakeNodeStatsMessage(s, counters_.clock().WallNs()).msg);
  if (final_report) final_sent_ = true;
}

}  // namespace hullpipe::dds
