// A tracked camera's pose as a live tracker reports it (paper §5: the fourth
// camera rode on the head-mounted display and was tracked with it): the
// tracker's timestamped world_from_camera samples, kept for a bounded while,
// sampled at a frame's capture time. The camera frame is OpenCV's (x right, y
// down, z forward; geometry/conventions.h); stamps are CLOCK_REALTIME
// nanoseconds, the clock of the frames' capture times.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <string>

#include "hullpipe/geometry/rigid3.h"

namespace hullpipe {

class LivePoseTrack {
 public:
  /// Samples kept (at a 1 kHz tracker, the last quarter second).
  static constexpr size_t kMaxSamples = 256;

  /// `max_hold_s`: how far past the newest sample (or before the oldest) a
  /// frame may be and take that end's pose, and half the widest gap between
  /// two samples a frame is interpolated across; (0, 1] s.
  explicit LivePoseTrack(double max_hold_s = 0.05);

  /// Adds one sample. Returns "" or why it is refused (the caller names it and
  /// counts it): a stamp not after the newest kept (a tracker's samples come in
  /// order), a rotation that is not one (IsRotation: orthonormal within 1e-6, det > 0), a
  /// translation that is not finite. The oldest sample goes past kMaxSamples.
  std::string Add(int64_t stamp_ns, const Rigid3d& world_from_camera);

  /// world_from_camera at `t_ns`: interpolated between the samples around it
  /// (position linearly, rotation by slerp) when they are at most 2 max_hold_s
  /// apart; the newest (oldest) sample's when t_ns is at most max_hold_s after
  /// (before) it; nullopt otherwise (no sample near enough: the frame cannot be
  /// posed).
  std::optional<Rigid3d> At(int64_t t_ns) const;

  /// Seconds from t_ns to the nearest sample (infinity when empty), for the
  /// line said when At gives nothing.
  double DistanceS(int64_t t_ns) const;

  size_t size() const { return samples_.size(); }

 private:
  struct Sample {
    int64_t stamp_ns;
    Rigid3d pose;
  };
  int64_t max_hold_ns_;
  std::deque<Sample> samples_;
};

}  // namespace hullpipe
