#include "hullpipe/dds/node.h"

#include <cstdlib>
#include <filesystem>
#include <vector>

#include <opencv2/core/utils/logger.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/geometry/conventions.h"

namespace hullpipe::dds {

void AddCommonOptions(CLI::App& app, CommonOptions& o) {
  app.add_option("--domain", o.domain, "DDS domain id")->capture_default_str();
  app.add_option("--dds-config", o.dds_config, "Cyclone DDS XML config file (sets CYCLONEDDS_URI)");
  app.add_option("--log-level", o.log_level, "trace|debug|info|warn|error")->capture_default_str();
}

std::unique_ptr<Participant> StartNode(const std::string& node_name, const CommonOptions& o) {
  spdlog::set_pattern("[%H:%M:%S.%e] [" + node_name + "] %^%l%$ %v");
  spdlog::set_level(spdlog::level::from_str(o.log_level));
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

NodeReporter::NodeReporter(const Participant& p, std::string name) : writer_(p), name_(std::move(name)) {}

NodeReporter::~NodeReporter() {
  try {
    Publish(true);
  } catch (...) {
  }
}

void NodeReporter::FrameOut(int64_t capture_time_ns) {
  ++frames_out_;
  const double now = MonotonicSeconds();
  if (first_out_s_ < 0) first_out_s_ = now;
  last_out_s_ = now;
  if (capture_time_ns > 0) latency_.Add(double(NowNs() - capture_time_ns) * 1e-6);
}

double NodeReporter::fps() const {
  if (frames_out_ < 2 || last_out_s_ <= first_out_s_) return 0;
  return double(frames_out_ - 1) / (last_out_s_ - first_out_s_);
}

void NodeReporter::Stage(const std::string& name, double ms) { stages_[name].Add(ms); }

void NodeReporter::Publish(bool final_report) {
  const double now = MonotonicSeconds();
  if (final_sent_ || (!final_report && now - last_publish_s_ < 0.5)) return;
  last_publish_s_ = now;
  std::vector<hullpipe_msg_StageTiming> stages;
  for (const auto& [n, s] : stages_)
    stages.push_back({const_cast<char*>(n.c_str()), s.Mean(), s.Percentile(95)});
  hullpipe_msg_NodeStats m{};
  m.node_name = const_cast<char*>(name_.c_str());
  m.stamp_ns = NowNs();
  m.frames_in = frames_in_;
  m.frames_out = frames_out_;
  m.dropped = dropped_;
  m.rejected = rejected_;
  m.fps = fps();
  m.latency_ms_p50 = latency_.Percentile(50);
  m.latency_ms_p95 = latency_.Percentile(95);
  m.stages._buffer = stages.data();
  m.stages._length = m.stages._maximum = uint32_t(stages.size());
  m.stages._release = false;
  m.final_report = final_report;
  writer_.Write(m);
  if (final_report) final_sent_ = true;
}

StageTimer::StageTimer(NodeReporter& r, std::string name)
    : reporter_(r), name_(std::move(name)), start_(MonotonicSeconds()) {}
StageTimer::~StageTimer() { reporter_.Stage(name_, ElapsedMs()); }
double StageTimer::ElapsedMs() const { return (MonotonicSeconds() - start_) * 1e3; }

}  // namespace hullpipe::dds
