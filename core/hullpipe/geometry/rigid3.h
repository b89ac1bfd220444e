// Rigid transforms `a_from_b` (see conventions.h for naming and frames).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hullpipe {

/// A rigid transform x_a = rotation * x_b + translation, named a_from_b by its users.
/// rotation is orthonormal with determinant +1; translation in metres.
struct Rigid3d {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  /// Applies the transform to a point (metres).
  Eigen::Vector3d operator*(const Eigen::Vector3d& x_b) const {
    return rotation * x_b + translation;
  }
  /// Composition: (a_from_b * b_from_c) is a_from_c.
  Rigid3d operator*(const Rigid3d& b_from_c) const {
    return {rotation * b_from_c.rotation, rotation * b_from_c.translation + translation};
  }
  /// b_from_a for this a_from_b.
  Rigid3d Inverse() const {
    const Eigen::Matrix3d rt = rotation.transpose();
    return {rt, -(rt * translation)};
  }
};

/// True if `r` is a rotation: finite, orthonormal (||r^T r - I|| below `tolerance`,
/// Frobenius) and of determinant > 0 (no reflection). The check a pose read from
/// outside (a tracker, a log, a message) must pass before it is used.
bool IsRotation(const Eigen::Matrix3d& r, double tolerance = 1e-6);

/// A camera-frame (x right, y down, z forward) pose at `eye` looking at `target`,
/// with image "up" as close as possible to `world_up`. Returns world_from_cam.
/// Errors: eye == target or view direction parallel to world_up gives an arbitrary
/// but valid orthonormal frame (never NaN).
Rigid3d LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
               const Eigen::Vector3d& world_up);

}  // namespace hullpipe
