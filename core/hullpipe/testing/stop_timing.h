// Test helper for the stop flag (util/interrupt.h): how long long work takes to
// end once its flag is set.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <optional>
#include <string>
#include <thread>

#include "hullpipe/testing/time_scale.h"  // TimeScale, for the bounds
#include "hullpipe/util/interrupt.h"

namespace hullpipe::test {

/// What StopAfter saw: the seconds from setting the flag to Interrupted, and its
/// what(); nullopt seconds if the work returned before the flag was set (a test
/// that proves nothing).
struct StopTiming {
  std::optional<double> seconds;
  std::string what;
};

/// Runs work(&flag) on this thread and sets the flag from another `delay` after
/// the start.
inline StopTiming StopAfter(std::chrono::milliseconds delay, const std::function<void(StopFlag)>& work) {
  using Clock = std::chrono::steady_clock;
  std::atomic<bool> stop{false};
  std::atomic<Clock::time_point> set_at{};
  std::thread setter([&] {
    std::this_thread::sleep_for(delay);
    set_at = Clock::now();
    stop = true;
  });
  StopTiming t;
  try {
    work(&stop);
  } catch (const Interrupted& e) {
    const auto ended = Clock::now();
    setter.join();
    t.seconds = std::chrono::duration<double>(ended - set_at.load()).count();
    t.what = e.what();
    return t;
  }
  setter.join();
  return t;
}

}  // namespace hullpipe::test
