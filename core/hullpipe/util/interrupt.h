// Stopping long work early. A node must stop within a second of SIGINT in every
// state (README, "Engineering rules"; docs/reliability.md), and some single
// calls can run for minutes within their documented bounds: a plane sweep of an
// 8192x8192 view with 4096 planes, a simulation step of a 100,000-vertex cloth
// with 200 iterations at 1e-4 s substeps. Such loops poll a caller's stop flag
// (the node's SIGINT flag) and end with Interrupted; their partial results are
// dropped, and a simulation interrupted mid-step is left part-way through that
// step (only good for stopping).
#pragma once

#include <atomic>
#include <stdexcept>
#include <string>

namespace hullpipe {

/// Thrown by a long loop whose stop flag was set; what() names the loop.
class Interrupted : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A flag that long loops poll; nullptr never stops them.
using StopFlag = const std::atomic<bool>*;

/// True once `stop` is set (a relaxed load: cheap enough to poll per pixel).
inline bool Stopped(StopFlag stop) { return stop != nullptr && stop->load(std::memory_order_relaxed); }

/// Throws Interrupted("<what> interrupted by a stop request") once `stop` is set.
inline void ThrowIfStopped(StopFlag stop, const char* what) {
  if (Stopped(stop)) throw Interrupted(std::string(what) + " interrupted by a stop request");
}

}  // namespace hullpipe
