// The motion of the visual hull's surface at a collision point: what the
// paper's response lacks (Lok et al. 2003, §4.2: "no information about the
// motion of the real objects, or of their hulls, is available") and its
// future work names as the cure ("keeping previous camera images ... would enable
// backtracking ... object velocity ... more accurate collision response").
//
// Two framesets' hulls, each with its cameras' capture times. At CP_hull with
// the outward normal N_hull, the line CP_hull + s N_hull is searched in both
// hulls by the exact ray–hull intervals (exact_hull.h), exactly as CP_hull is
// found: the surface crossing (the hull left going along +N) nearest CP_hull in
// the current hull and the one nearest it in the previous hull. Their distance
// along N over the time between them is the surface's normal speed (positive:
// the surface moves outward, toward what it touches). The time is that of the
// cameras whose silhouette cones form the two crossings (HullSurfaceNormal's
// cameras; their mean on a hull edge, where two cones meet), so cameras that do
// not shoot together (skew) are timed as they shot.
//
// Only the normal part is measured. A silhouette carries no texture to follow,
// so a surface sliding along itself (a turning ball, a hand moving along its
// own surface) looks the same from frame to frame: the tangential velocity is
// not observable at a point (the aperture problem), and the frictionless §4.2
// response does not use it. docs/collision.md, "Hull velocity".
//
// Frames: world metres; times in seconds on the clock the scene steps by.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe {

/// Settings of the hull's velocity at contacts (the scene file's
/// `hull_velocity` keys, scene_config.h).
struct HullMotionOptions {
  bool enabled = true;       ///< false: the response sees a stationary hull (paper §4.2 as published).
  /// A physical bound on the surface's normal speed (m/s): faster estimates are
  /// clamped to it (HullVelocityStatus::kClamped). A crossing in the previous
  /// hull more than twice this bound times the interval away is no longer taken
  /// for the same surface (kAppeared).
  double max_speed = 10.0;
  /// Framesets further apart than this (seconds, capture time) give no velocity
  /// (kTooFarApart): the surface may have come and gone in between.
  double max_interval = 0.1;
  /// Throws std::invalid_argument naming the bad field (as its scene key).
  void Check() const;
};

/// What a hull velocity estimate is (values as the IDL's HULL_VELOCITY_*).
enum class HullVelocityStatus : uint8_t {
  kNone = 0,         ///< Not estimated (no response; turned off; a recording older than the field).
  kMeasured = 1,     ///< normal_speed is the estimate.
  kClamped = 2,      ///< The estimate exceeded max_speed: normal_speed is +-max_speed.
  kNoPrevious = 3,   ///< No previous frameset of the same cameras.
  kTooFarApart = 4,  ///< The framesets (or the forming cameras' frames) are more than max_interval apart.
  kAppeared = 5,     ///< No surface of the previous hull within reach on the line: the hull appeared there.
};

/// "measured", "clamped", ... (for logs and tables).
const char* ToString(HullVelocityStatus status);

/// The hull's surface velocity at one contact.
struct HullVelocity {
  HullVelocityStatus status = HullVelocityStatus::kNone;
  /// Metres per second along N_hull, positive outward; 0 unless valid().
  double normal_speed = 0;
  /// Seconds between the two crossings' frames (0 unless valid()).
  double interval_s = 0;
  /// Metres the surface moved along N_hull (the estimate before clamping; 0
  /// unless valid()).
  double displacement = 0;
  bool valid() const { return status == HullVelocityStatus::kMeasured || status == HullVelocityStatus::kClamped; }
};

/// One frameset's hull and when its cameras shot it.
struct TimedHull {
  const VolumeQuery* query = nullptr;  ///< nullptr: no hull.
  /// The frameset's reference time (ns) on the clock the scene steps by:
  /// sim_node gives the frames' source time (a live camera's capture time; a
  /// file's own timeline, also when capture plays it slower than recorded).
  int64_t time_ns = 0;
  /// Capture time of each view in query->views() order (ns, the same clock);
  /// empty: every view at time_ns.
  std::vector<int64_t> view_time_ns;
  /// The camera ids of the views, in query->views() order (two framesets are
  /// compared only if they match).
  std::vector<int> camera_ids;
  /// A TimedHull of a frameset: its maps' camera ids, its reference time
  /// time_ns, and per view time_ns + skew_ns[i] (each map's capture time minus
  /// the reference camera's: Frameset::skew_ns; ignored unless one per view).
  static TimedHull Of(const VolumeQuery& query, int64_t time_ns, const std::vector<int64_t>& skew_ns);
};

/// The current and the previous frameset's hulls: estimates the surface's
/// normal velocity at contacts against the current one. Immutable; At() is
/// thread-safe.
class HullMotion {
 public:
  /// Throws std::invalid_argument if options fail Check(). `previous.query`
  /// may be nullptr (no previous frameset: every estimate is kNoPrevious).
  HullMotion(TimedHull current, TimedHull previous, const HullMotionOptions& options = {});
  /// The normal velocity of the current hull's surface at cp_hull (world
  /// metres, on the current hull's surface: CP_hull of §4.2) along n_hull
  /// (outward unit normal there, N_hull). Two exact ray–hull interval searches
  /// on the line cp_hull + s n_hull, |s| <= 2 max_speed interval, and two
  /// HullSurfaceNormal calls to find the forming cameras (hull_surface.h).
  /// kNone if options().enabled is false or the line leaves the current hull
  /// nowhere near cp_hull (not a surface point).
  HullVelocity At(const Eigen::Vector3d& cp_hull, const Eigen::Vector3d& n_hull) const;
  const HullMotionOptions& options() const { return options_; }
  /// Seconds between the framesets' reference times (0 without a previous).
  double interval_s() const { return interval_s_; }

 private:
  TimedHull current_, previous_;
  HullMotionOptions options_;
  bool comparable_ = false;
  double interval_s_ = 0;
};

/// The §4.2 velocity change of a body in contact with a moving surface: the
/// body's velocity relative to the surface, u = hull.normal_speed n (when
/// hull.valid()), reflected about n (unit) if it points into the hull,
/// v -= (1 + restitution) ((v - u) . n) n. With no valid hull velocity (or a
/// zero one) exactly the paper's v -= (1 + restitution) (v . n) n for v . n < 0.
/// A body at rest struck by a surface moving at w along n leaves at (1 + e) w.
void ReflectOffMovingSurface(const Eigen::Vector3d& n, const HullVelocity& hull, double restitution,
                             Eigen::Vector3d* velocity);

}  // namespace hullpipe
