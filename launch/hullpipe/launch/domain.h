// DDS domain ids for runs that share a machine (parallel tests, node_bench):
// each lease holds an exclusive lock on one id's lock file, so no two live
// processes get the same domain, whatever their pids.
#pragma once

#include <cstdint>

#include "hullpipe/util/run_id.h"  // kMaxDomainId

namespace hullpipe::launch {

/// An exclusively held DDS domain id in [first, last] (0..kMaxDomainId).
/// Released when destroyed (or when the process ends, even by SIGKILL).
class DomainLease {
 public:
  /// Takes the lowest free id in [first, last], starting from a per-process
  /// offset; throws std::runtime_error if all are held.
  DomainLease(uint32_t first = 100, uint32_t last = 229);
  ~DomainLease();
  DomainLease(const DomainLease&) = delete;
  DomainLease& operator=(const DomainLease&) = delete;
  DomainLease(DomainLease&& other) noexcept;
  DomainLease& operator=(DomainLease&& other) noexcept;
  uint32_t id() const { return id_; }

 private:
  uint32_t id_ = 0;
  int fd_ = -1;
};

}  // namespace hullpipe::launch
