#include "hullpipe/util/reject_log.h"

#include <spdlog/spdlog.h>

namespace hullpipe {

bool RejectLog::Log(const std::string& why, double now_s) {
  std::lock_guard lock(mutex_);
  if (lines_ >= kBurst && now_s - last_line_s_ < 1.0) {
    ++unlogged_;
    return false;
  }
  if (unlogged_ > 0)
    spdlog::warn("rejected: {} ({} more rejected since the last such line, not written; all counted)", why,
                 unlogged_);
  else
    spdlog::warn("rejected: {}", why);
  ++lines_;
  unlogged_ = 0;
  last_line_s_ = now_s;
  return true;
}

}  // namespace hullpipe
