// One run's samples only (docs/reliability.md, "run id"). Every node of a run
// gets the same --run-id (hullpipe_launch makes one); ViewPose, HullView and
// NodeStats carry it. A sample of another run on the same domain (a replayed
// recording's outputs, a forgotten node of an earlier run) is ignored, counted,
// and named in one warning per kind and run id, instead of being mixed into
// this run's frames and its stats.json.
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <utility>

#include "hullpipe/util/run_id.h"

namespace hullpipe::nodes {

class RunFilter {
 public:
  /// run_id: this run's (0: none given; then every sample is taken).
  explicit RunFilter(uint64_t run_id) : run_id_(run_id) {}
  /// Whether a sample of `kind` ("ViewPose", "HullView", "NodeStats") with run
  /// id `id` belongs to this run. A sample without a run id (0) is taken when
  /// `take_unset` (reports of nodes started by hand without --run-id).
  /// Otherwise the sample is counted under `kind` and, the first time for that
  /// kind and id, a warning names both runs and `from` (e.g. the node's name).
  bool Accept(uint64_t id, const std::string& kind, bool take_unset, const std::string& from = "");
  uint64_t run_id() const { return run_id_; }
  /// Samples ignored so far, by kind.
  const std::map<std::string, uint64_t>& ignored() const { return ignored_; }

 private:
  uint64_t run_id_;
  std::map<std::string, uint64_t> ignored_;
  std::set<std::pair<std::string, uint64_t>> warned_;
};

}  // namespace hullpipe::nodes
