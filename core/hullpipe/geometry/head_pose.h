// The user's head-tracked viewpoint (paper §3: the parent pipe renders for the
// tracked head). A track of timestamped eye poses, from a tracker's CSV log or
// accumulated from a live tracker topic, sampled at any time.
//
// Pose convention: world_from_eye, the eye frame is OpenCV's camera frame (x
// right, y down, z forward, the view direction), world frame of the rig, metres.
// CSV columns: t,x,y,z,qw,qx,qy,qz — t in seconds (for a file, seconds from the
// first frame of the input, the same clock as the frames' source time), x y z the
// eye centre in world metres, q the rotation world_from_eye as a unit quaternion
// (normalised on reading).
#pragma once

#include <string>
#include <vector>

#include "hullpipe/geometry/rigid3.h"

namespace hullpipe {

/// One tracked pose.
struct TimedPose {
  double t = 0;           ///< Seconds.
  Rigid3d world_from_eye;
};

/// Timestamped eye poses, sampled by linear interpolation of the position and
/// spherical interpolation of the rotation; held at the ends.
class PoseTrack {
 public:
  PoseTrack() = default;
  /// Poses in any order (sorted here). Throws std::invalid_argument if two share
  /// a time or a rotation is not orthonormal.
  explicit PoseTrack(std::vector<TimedPose> poses);
  bool empty() const { return poses_.empty(); }
  size_t size() const { return poses_.size(); }
  /// The pose at time t. Throws std::logic_error on an empty track.
  Rigid3d At(double t) const;

 private:
  std::vector<TimedPose> poses_;
};

/// Reads a pose CSV (format above; a first line that is not numbers is a header;
/// '#' lines are comments). Throws std::runtime_error naming the file and line for
/// a missing file, a wrong column count, a non-number, a non-finite value, a zero
/// quaternion or duplicate times.
PoseTrack LoadPoseTrack(const std::string& path);

}  // namespace hullpipe
