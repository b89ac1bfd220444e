// The warning line a node writes for each input sample it rejects, bounded: a
// peer sending bad samples as fast as it can must not flood the node's log
// (docs/reliability.md). Every rejected sample is still counted (the node's
// `rejected`, stats.json); only the lines are bounded.
#pragma once

#include <cstdint>
#include <mutex>
#include <string>

namespace hullpipe {

/// Writes "rejected: <why>" to the log (spdlog warn) for the first kBurst
/// samples, then at most one line a second: the latest sample's reason and how
/// many rejected samples went unlogged since the last line. Thread-safe.
class RejectLog {
 public:
  /// Rejections logged in full before the once-a-second lines.
  static constexpr int64_t kBurst = 20;
  /// One rejected sample at `now_s` (the node's clock, seconds). Returns
  /// whether a line was written.
  bool Log(const std::string& why, double now_s);
  /// Lines written, and rejections not written since the last line.
  int64_t lines() const {
    std::lock_guard lock(mutex_);
    return lines_;
  }
  int64_t unlogged() const {
    std::lock_guard lock(mutex_);
    return unlogged_;
  }

 private:
  mutable std::mutex mutex_;
  int64_t lines_ = 0, unlogged_ = 0;
  double last_line_s_ = 0;
};

}  // namespace hullpipe
