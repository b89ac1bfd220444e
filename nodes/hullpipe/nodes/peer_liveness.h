// Which peers are alive, from when each was last heard (its NodeStats, about
// twice a second): the one liveness rule of render_node (which notices a silent
// recon node) and recon_node (whose lowest live node adopts a silent peer's
// tile). A peer that sent its final report is gone at once.
//
// Load stretches a peer's report gaps (a 20-camera rig on a busy machine made a
// recon node's reports 1 s apart and render declared it silent, to hear it again
// 0.06 s later): each peer's threshold is therefore the larger of silence_s and
// 3x the longest of its last 16 report gaps, capped at 10 x silence_s. A peer
// that really stops is still declared silent, at most 10 x silence_s later.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace hullpipe::nodes {

class PeerLiveness {
 public:
  /// silence_s: a peer not heard for longer than this is silent. Throws
  /// std::invalid_argument unless 0 < silence_s <= 3600.
  explicit PeerLiveness(double silence_s);
  /// Starts tracking `peer` as if heard at `now` (a peer expected from the start).
  void Expect(const std::string& peer, double now);
  /// `peer` reported at `now`; `final_report`: it is stopping (silent at once).
  void Heard(const std::string& peer, double now, bool final_report = false);
  /// Heard within silence_s of `now` (and no final report since). Unknown: false.
  bool Alive(const std::string& peer, double now) const;
  /// A peer's state changed since the last Update.
  struct Change {
    std::string peer;
    bool silent = false;  ///< true: fell silent; false: heard again.
  };
  /// The changes at `now`, in peer order; each fall into silence counts an outage.
  std::vector<Change> Update(double now);
  /// Times each peer fell silent.
  const std::map<std::string, int>& outages() const { return outages_; }
  double silence_s() const { return silence_s_; }
  /// The threshold in force for `peer` now (silence_s until gaps are seen).
  double ThresholdFor(const std::string& peer) const;

 private:
  double silence_s_;
  std::map<std::string, double> heard_;   // peer -> last heard (-inf after a final report)
  std::map<std::string, bool> silent_;    // peer -> silent at the last Update
  std::map<std::string, int> outages_;
  std::map<std::string, std::vector<double>> gaps_;  // peer -> its last 16 report gaps
};

}  // namespace hullpipe::nodes
