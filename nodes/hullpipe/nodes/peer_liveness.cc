#include "hullpipe/nodes/peer_liveness.h"

#include <algorithm>
#include <cmath>

#include <limits>
#include <stdexcept>

namespace hullpipe::nodes {

PeerLiveness::PeerLiveness(double silence_s) : silence_s_(silence_s) {
  if (!(silence_s > 0 && silence_s <= 3600)) throw std::invalid_argument("peer silence must be in (0, 3600] s");
}

void PeerLiveness::Expect(const std::string& peer, double now) {
  heard_.try_emplace(peer, now);
  silent_.try_emplace(peer, false);
}

void PeerLiveness::Heard(const std::string& peer, double now, bool final_report) {
  const auto it = heard_.find(peer);
  if (it != heard_.end() && std::isfinite(it->second) && now > it->second && !final_report) {
    auto& g = gaps_[peer];
    g.push_back(now - it->second);
    if (g.size() > 16) g.erase(g.begin());
  }
  heard_[peer] = final_report ? -std::numeric_limits<double>::infinity() : now;
  silent_.try_emplace(peer, false);
}

double PeerLiveness::ThresholdFor(const std::string& peer) const {
  const auto g = gaps_.find(peer);
  if (g == gaps_.end() || g->second.empty()) return silence_s_;
  const double longest = *std::max_element(g->second.begin(), g->second.end());
  return std::clamp(3.0 * longest, silence_s_, 10.0 * silence_s_);
}

bool PeerLiveness::Alive(const std::string& peer, double now) const {
  const auto it = heard_.find(peer);
  return it != heard_.end() && now - it->second <= ThresholdFor(peer);
}

std::vector<PeerLiveness::Change> PeerLiveness::Update(double now) {
  std::vector<Change> changes;
  for (const auto& [peer, heard] : heard_) {
    const bool silent = !Alive(peer, now);
    bool& was = silent_[peer];
    if (silent == was) continue;
    was = silent;
    if (silent) ++outages_[peer];
    changes.push_back({peer, silent});
  }
  return changes;
}

}  // namespace hullpipe::nodes
