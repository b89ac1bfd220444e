#include "hullpipe/capture/live_pose_track.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Geometry>

namespace hullpipe {

LivePoseTrack::LivePoseTrack(double max_hold_s) : max_hold_ns_(int64_t(std::llround(max_hold_s * 1e9))) {
  if (!(max_hold_s > 0 && max_hold_s <= 1)) throw std::invalid_argument("LivePoseTrack: max_hold_s must be in (0, 1]");
}

std::string LivePoseTrack::Add(int64_t stamp_ns, const Rigid3d& pose) {
  if (!IsRotation(pose.rotation)) return "its rotation is not a rotation";
  if (!pose.translation.allFinite()) return "its translation is not finite";
  if (!samples_.empty() && !(stamp_ns > samples_.back().stamp_ns))
    return "its stamp is not after the newest sample's (" + std::to_string(samples_.back().stamp_ns) + " ns)";
  samples_.push_back({stamp_ns, pose});
  while (samples_.size() > kMaxSamples) samples_.pop_front();
  return "";
}

std::optional<Rigid3d> LivePoseTrack::At(int64_t t) const {
  if (samples_.empty()) return std::nullopt;
  const Sample& first = samples_.front();
  const Sample& last = samples_.back();
  if (t >= last.stamp_ns) {
    if (t - last.stamp_ns <= max_hold_ns_) return last.pose;
    return std::nullopt;
  }
  if (t <= first.stamp_ns) {
    if (first.stamp_ns - t <= max_hold_ns_) return first.pose;
    return std::nullopt;
  }
  const auto hi = std::upper_bound(samples_.begin(), samples_.end(), t,
                                   [](int64_t x, const Sample& s) { return x < s.stamp_ns; });
  const auto lo = hi - 1;
  if (hi->stamp_ns - lo->stamp_ns > 2 * max_hold_ns_) {
    // A gap in the tracker's samples: an end near enough holds, else nothing.
    if (t - lo->stamp_ns <= max_hold_ns_) return lo->pose;
    if (hi->stamp_ns - t <= max_hold_ns_) return hi->pose;
    return std::nullopt;
  }
  const double a = double(t - lo->stamp_ns) / double(hi->stamp_ns - lo->stamp_ns);
  const Eigen::Quaterniond q0(lo->pose.rotation), q1(hi->pose.rotation);
  Rigid3d out;
  out.rotation = q0.slerp(a, q1).toRotationMatrix();
  out.translation = (1 - a) * lo->pose.translation + a * hi->pose.translation;
  return out;
}

double LivePoseTrack::DistanceS(int64_t t) const {
  double best = std::numeric_limits<double>::infinity();
  for (const Sample& s : samples_) best = std::min(best, std::abs(double(t - s.stamp_ns)) * 1e-9);
  return best;
}

}  // namespace hullpipe
