#include "hullpipe/geometry/rigid3.h"

namespace hullpipe {

bool IsRotation(const Eigen::Matrix3d& r, double tolerance) {
  return r.allFinite() && (r.transpose() * r - Eigen::Matrix3d::Identity()).norm() < tolerance && r.determinant() > 0;
}

Rigid3d LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
               const Eigen::Vector3d& world_up) {
  Eigen::Vector3d z = target - eye;
  if (z.norm() < 1e-12) z = Eigen::Vector3d::UnitZ();
  z.normalize();
  // Camera y points down in the image (y = -up), and x = y cross z.
  Eigen::Vector3d x = z.cross(world_up);
  if (x.norm() < 1e-9) x = z.unitOrthogonal();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Rigid3d world_from_cam;
  world_from_cam.rotation.col(0) = x;
  world_from_cam.rotation.col(1) = y;
  world_from_cam.rotation.col(2) = z;
  world_from_cam.translation = eye;
  return world_from_cam;
}

}  // namespace hullpipe
