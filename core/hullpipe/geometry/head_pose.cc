#include "hullpipe/geometry/head_pose.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "hullpipe/util/csv.h"

namespace hullpipe {

PoseTrack::PoseTrack(std::vector<TimedPose> poses) : poses_(std::move(poses)) {
  std::sort(poses_.begin(), poses_.end(), [](const TimedPose& a, const TimedPose& b) { return a.t < b.t; });
  for (size_t i = 0; i < poses_.size(); ++i) {
    if (!IsRotation(poses_[i].world_from_eye.rotation))
      throw std::invalid_argument("PoseTrack: pose " + std::to_string(i) + " has no rotation");
    if (i > 0 && !(poses_[i].t > poses_[i - 1].t))
      throw std::invalid_argument("PoseTrack: two poses at t = " + std::to_string(poses_[i].t));
  }
}

Rigid3d PoseTrack::At(double t) const {
  if (poses_.empty()) throw std::logic_error("PoseTrack::At on an empty track");
  if (!(t > poses_.front().t)) return poses_.front().world_from_eye;
  if (t >= poses_.back().t) return poses_.back().world_from_eye;
  const auto hi = std::upper_bound(poses_.begin(), poses_.end(), t,
                                   [](double x, const TimedPose& p) { return x < p.t; });
  const auto lo = hi - 1;
  const double a = (t - lo->t) / (hi->t - lo->t);
  const Eigen::Quaterniond q0(lo->world_from_eye.rotation), q1(hi->world_from_eye.rotation);
  Rigid3d out;
  out.rotation = q0.slerp(a, q1).toRotationMatrix();
  out.translation = (1 - a) * lo->world_from_eye.translation + a * hi->world_from_eye.translation;
  return out;
}

PoseTrack LoadPoseTrack(const std::string& path) {
  std::vector<TimedPose> poses;
  for (const CsvRow& row : ReadNumericCsv(path, 8, "t,x,y,z,qw,qx,qy,qz")) {
    const auto& v = row.values;
    Eigen::Quaterniond q(v[4], v[5], v[6], v[7]);
    if (!(q.norm() > 1e-9)) throw std::runtime_error(CsvWhere(path, row.line) + "zero quaternion");
    q.normalize();
    TimedPose p;
    p.t = v[0];
    p.world_from_eye.rotation = q.toRotationMatrix();
    p.world_from_eye.translation = Eigen::Vector3d(v[1], v[2], v[3]);
    poses.push_back(p);
  }
  try {
    return PoseTrack(std::move(poses));
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
}

}  // namespace hullpipe
