#include "hullpipe/nodes/run_filter.h"


#include <spdlog/spdlog.h>

namespace hullpipe::nodes {

bool RunFilter::Accept(uint64_t id, const std::string& kind, bool take_unset, const std::string& from) {
  if (run_id_ == 0 || id == run_id_ || (id == 0 && take_unset)) return true;
  ++ignored_[kind];
  // One warning per kind and run id, for the first 16 such pairs (a peer
  // cycling through run ids gets no more memory or lines).
  if (warned_.size() < 16 && warned_.insert({kind, id}).second)
    spdlog::warn("ignoring {} samples{} of another run (run id {}; this run is {}): a replay or another run "
                 "shares this DDS domain",
                 kind, from.empty() ? "" : " from " + from, id ? RunIdText(id) : "none", RunIdText(run_id_));
  return false;
}

}  // namespace hullpipe::nodes
