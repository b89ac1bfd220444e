// The time a node controller runs on, injected so unit tests drive controllers
// with fake time (docs/architecture.md, "Thin mains").
#pragma once

#include <chrono>
#include <cstdint>
#include <thread>

#include "hullpipe/geometry/conventions.h"

namespace hullpipe {

/// Monotonic seconds (timeouts, rates) and the wall clock in ns since the Unix
/// epoch (capture times, which cross processes and hosts).
class Clock {
 public:
  virtual ~Clock() = default;
  /// Monotonic seconds from an arbitrary origin.
  virtual double Now() const = 0;
  /// Wall-clock nanoseconds since the Unix epoch.
  virtual int64_t WallNs() const = 0;
  /// Blocks until Now() >= t (returns at once if it already is).
  virtual void SleepUntil(double t) const = 0;
};

/// The process's clocks (conventions.h's MonotonicSeconds and NowNs).
class SystemClock final : public Clock {
 public:
  double Now() const override { return MonotonicSeconds(); }
  int64_t WallNs() const override { return NowNs(); }
  void SleepUntil(double t) const override {
    const double dt = t - Now();
    if (dt > 0) std::this_thread::sleep_for(std::chrono::duration<double>(dt));
  }
};

/// Time that moves only when told: SleepUntil jumps to the wake-up time. The
/// wall clock is the monotonic one plus a fixed offset.
class FakeClock final : public Clock {
 public:
  explicit FakeClock(double start_s = 100.0, int64_t wall_offset_ns = 1'700'000'000'000'000'000)
      : now_(start_s), wall_offset_ns_(wall_offset_ns) {}
  double Now() const override { return now_; }
  int64_t WallNs() const override { return wall_offset_ns_ + int64_t(now_ * 1e9); }
  void SleepUntil(double t) const override {
    if (t > now_) now_ = t;
  }
  void Advance(double dt) { now_ += dt; }

 private:
  mutable double now_;
  int64_t wall_offset_ns_;
};

}  // namespace hullpipe
