#include "hullpipe/collision/hull_motion.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "hullpipe/collision/hull_surface.h"
#include "hullpipe/reconstruction/exact_hull.h"

namespace hullpipe {

namespace {

// The exit (interval end: the hull left going along +dir) nearest s among
// intervals on [0, s_end]; an interval ending at s_end is clipped, not left.
std::optional<double> NearestExit(const Intervals& iv, double s, double s_end) {
  std::optional<double> best;
  for (const auto& [a, b] : iv) {
    (void)a;
    if (b >= s_end * (1 - 1e-12)) continue;
    if (!best || std::abs(b - s) < std::abs(*best - s)) best = b;
  }
  return best;
}

// Capture time (ns) of the view whose cone forms the surface at X -- the mean
// of the views that form it on a hull edge or corner, where each shot its own
// side of it -- or the frameset's reference time where that is not known.
int64_t FormingTime(const TimedHull& h, const Eigen::Vector3d& X) {
  if (h.view_time_ns.empty()) return h.time_ns;
  const auto n = HullSurfaceNormal(*h.query, X);
  if (!n || n->cameras.empty()) return h.time_ns;
  int64_t sum = 0;
  for (const int c : n->cameras) {
    if (c < 0 || size_t(c) >= h.view_time_ns.size()) return h.time_ns;
    sum += h.view_time_ns[size_t(c)] - h.time_ns;
  }
  return h.time_ns + sum / int64_t(n->cameras.size());
}

int64_t Spread(const TimedHull& h) {
  int64_t s = 0;
  for (const int64_t t : h.view_time_ns) s = std::max(s, t > h.time_ns ? t - h.time_ns : h.time_ns - t);
  return s;
}

}  // namespace

void HullMotionOptions::Check() const {
  if (!(std::isfinite(max_speed) && max_speed > 0 && max_speed <= 1000))
    throw std::invalid_argument("hull_velocity.max_speed must be in (0, 1000] m/s");
  if (!(std::isfinite(max_interval) && max_interval > 0 && max_interval <= 10))
    throw std::invalid_argument("hull_velocity.max_interval must be in (0, 10] s");
}

const char* ToString(HullVelocityStatus status) {
  switch (status) {
    case HullVelocityStatus::kNone: return "none";
    case HullVelocityStatus::kMeasured: return "measured";
    case HullVelocityStatus::kClamped: return "clamped";
    case HullVelocityStatus::kNoPrevious: return "no previous frameset";
    case HullVelocityStatus::kTooFarApart: return "framesets too far apart";
    case HullVelocityStatus::kAppeared: return "appeared";
  }
  return "unknown";
}

TimedHull TimedHull::Of(const VolumeQuery& query, int64_t time_ns, const std::vector<int64_t>& skew_ns) {
  TimedHull h;
  h.query = &query;
  h.time_ns = time_ns;
  for (const CameraMap& v : query.views()) h.camera_ids.push_back(v.camera.id);
  if (skew_ns.size() == query.views().size())
    for (const int64_t s : skew_ns) h.view_time_ns.push_back(time_ns + s);
  return h;
}

HullMotion::HullMotion(TimedHull current, TimedHull previous, const HullMotionOptions& options)
    : current_(std::move(current)), previous_(std::move(previous)), options_(options) {
  options_.Check();
  comparable_ = current_.query && previous_.query && current_.camera_ids == previous_.camera_ids &&
                current_.time_ns > previous_.time_ns;
  if (comparable_) interval_s_ = double(current_.time_ns - previous_.time_ns) * 1e-9;
}

HullVelocity HullMotion::At(const Eigen::Vector3d& cp_hull, const Eigen::Vector3d& n_hull) const {
  HullVelocity v;
  if (!options_.enabled || !current_.query) return v;
  if (!comparable_) {
    v.status = HullVelocityStatus::kNoPrevious;
    return v;
  }
  if (interval_s_ > options_.max_interval) {
    v.status = HullVelocityStatus::kTooFarApart;
    return v;
  }
  const double n_len = n_hull.norm();
  if (!(n_len > 0) || !cp_hull.allFinite()) return v;
  const Eigen::Vector3d n = n_hull / n_len;
  // The line through CP_hull along N, far enough either way to hold any
  // surface that moved at up to twice the bound in the longest interval that
  // the two framesets' cameras can span.
  const double span_s = interval_s_ + double(Spread(current_) + Spread(previous_)) * 1e-9;
  const double reach = std::max(2 * options_.max_speed * span_s, 1e-3);
  const Eigen::Vector3d origin = cp_hull - reach * n;
  const double s_end = 2 * reach;
  // Both hulls searched the same way on the same line: identical hulls give
  // identical crossings, so a stationary hull gives exactly zero.
  const auto s_cur = NearestExit(RayHullIntervals(*current_.query, origin, n, 0.0, s_end), reach, s_end);
  if (!s_cur || std::abs(*s_cur - reach) > 0.5 * reach) return v;  // cp_hull is not on this surface
  const auto s_prev = NearestExit(RayHullIntervals(*previous_.query, origin, n, 0.0, s_end), *s_cur, s_end);
  if (!s_prev) {
    v.status = HullVelocityStatus::kAppeared;
    return v;
  }
  const double d = *s_cur - *s_prev;
  // Timed by the cameras whose cones form the two crossings (they may not have
  // shot at the frameset's reference time); the framesets' interval where that
  // gives no positive time.
  int64_t dt_ns = FormingTime(current_, origin + *s_cur * n) - FormingTime(previous_, origin + *s_prev * n);
  if (dt_ns <= 0) dt_ns = current_.time_ns - previous_.time_ns;
  const double dt = double(dt_ns) * 1e-9;
  if (dt > options_.max_interval) {
    v.status = HullVelocityStatus::kTooFarApart;
    return v;
  }
  if (std::abs(d) > 2 * options_.max_speed * dt) {
    v.status = HullVelocityStatus::kAppeared;  // too far to be the same surface
    return v;
  }
  v.displacement = d;
  v.interval_s = dt;
  v.normal_speed = d / dt;
  v.status = HullVelocityStatus::kMeasured;
  if (std::abs(v.normal_speed) > options_.max_speed) {
    v.normal_speed = std::copysign(options_.max_speed, v.normal_speed);
    v.status = HullVelocityStatus::kClamped;
  }
  return v;
}

void ReflectOffMovingSurface(const Eigen::Vector3d& n, const HullVelocity& hull, double restitution,
                             Eigen::Vector3d* velocity) {
  const double vn = velocity->dot(n);
  if (!hull.valid() || hull.normal_speed == 0) {
    if (vn < 0) *velocity -= (1 + restitution) * vn * n;  // the paper's §4.2, exactly
    return;
  }
  const double relative = vn - hull.normal_speed;
  if (relative < 0) *velocity -= (1 + restitution) * relative * n;
}

}  // namespace hullpipe
