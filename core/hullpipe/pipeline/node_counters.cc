#include "hullpipe/pipeline/node_counters.h"

#include <unistd.h>

namespace hullpipe {

NodeCounters::NodeCounters(const Clock& clock) : clock_(clock) {
  char host[256] = {};
  if (gethostname(host, sizeof host - 1) == 0) host_ = host;
}

void NodeCounters::FrameOut(int64_t capture_time_ns) {
  ++frames_out_;
  const double now = clock_.Now();
  if (first_out_s_ < 0) first_out_s_ = now;
  last_out_s_ = now;
  if (capture_time_ns > 0) latency_.Add(double(clock_.WallNs() - capture_time_ns) * 1e-6);
}

double NodeCounters::fps() const {
  if (frames_out_ < 2 || last_out_s_ <= first_out_s_) return 0;
  return double(frames_out_ - 1) / (last_out_s_ - first_out_s_);
}

NodeStatsSample NodeCounters::Snapshot(const std::string& name, bool final_report) const {
  NodeStatsSample s;
  s.name = name;
  s.fps = fps();
  s.latency_ms_p50 = latency_.Percentile(50);
  s.latency_ms_p95 = latency_.Percentile(95);
  s.frames_in = frames_in_;
  s.frames_out = frames_out_;
  s.dropped = dropped_;
  s.rejected = rejected_;
  s.final_report = final_report;
  for (const auto& [n, st] : stages_) s.stages[n] = {st.Mean(), st.Percentile(50), st.Percentile(95), st.count()};
  s.cameras = cameras_;
  s.dropped_for_skew = dropped_for_skew_;
  s.backend = backend_;
  s.host = host_;
  return s;
}

}  // namespace hullpipe
