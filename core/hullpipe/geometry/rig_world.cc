#include "hullpipe/geometry/rig_world.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <Eigen/Dense>
#include <opencv2/core.hpp>

namespace hullpipe {
namespace {

// A distance for a message: 4 significant digits at any size ("2.147e+09",
// where int() printed -2147483648).
std::string FormatMetres(double m) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", m);
  return b;
}


constexpr double kPi = 3.14159265358979323846;
double Deg(double rad) { return rad * 180.0 / kPi; }
double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return Deg(std::atan2(a.cross(b).norm(), a.dot(b)));
}
std::string Vec(const Eigen::Vector3d& v, int decimals = 2) {
  char b[96];
  std::snprintf(b, sizeof b, "(%.*f, %.*f, %.*f)", decimals, v.x(), decimals, v.y(), decimals, v.z());
  return b;
}
Eigen::Vector3d ViewDir(const Camera& c) { return c.cam_from_world.rotation.row(2).transpose(); }

// The point nearest to every camera's optical axis (least squares), or the mean
// centre when the axes are (near) parallel.
Eigen::Vector3d LookAtPoint(const std::vector<Camera>& cameras) {
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero(), mean = Eigen::Vector3d::Zero();
  for (const auto& c : cameras) {
    const Eigen::Vector3d d = ViewDir(c);
    const Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - d * d.transpose();
    a += p;
    b += p * c.Center();
    mean += c.Center();
  }
  if (cameras.empty()) return mean;
  mean /= double(cameras.size());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(a);  // a is symmetric, PSD
  const Eigen::Vector3d ev = eig.eigenvalues();                  // ascending
  if (ev(0) < 1e-6 * std::max(1.0, ev(2))) return mean;
  return eig.eigenvectors() * (eig.eigenvectors().transpose() * b).cwiseQuotient(ev);
}

}  // namespace

void RigWorld::Check() const {
  auto bad = [](const std::string& what) { throw std::invalid_argument("world: " + what); };
  if (!up.allFinite() || up.norm() < 1e-9) bad("'up' must be a finite non-zero vector");
  if (!std::isfinite(floor_height)) bad("'floor' must be finite");
  if (!(std::isfinite(orbit_radius) && orbit_radius > 0)) bad("'orbit_radius' must be > 0 m");
  if (!std::isfinite(orbit_height)) bad("'orbit_height' must be finite");
}

std::string RigWorld::FloorText() const {
  if (floor == Floor::kNone) return "none";
  if (floor == Floor::kUnderHull) return "under the first hull";
  char b[64];
  std::snprintf(b, sizeof b, "plane up . x = %.3f m", floor_height);
  return b;
}

UpEstimates EstimateUp(const std::vector<Camera>& cameras) {
  UpEstimates e;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& c : cameras) sum -= c.cam_from_world.rotation.row(1).transpose();  // R^T (0,-1,0)
  if (cameras.empty() || sum.norm() < 0.2 * double(cameras.size())) return e;
  e.mean_image_up = sum.normalized();
  // Level cameras: up is normal to every image x-axis.
  auto normal_to = [&](const std::vector<Eigen::Vector3d>& xs) -> std::optional<Eigen::Vector3d> {
    if (xs.size() < 2) return std::nullopt;
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    for (const auto& x : xs) m += x * x.transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(m);  // ascending
    // x-axes all near one line: the middle eigenvalue is n sin^2 of their spread
    // (about); under 0.02 n (~16 degrees) the normal is not pinned down.
    if (eig.eigenvalues()(1) < 0.02 * double(xs.size())) return std::nullopt;
    Eigen::Vector3d up = eig.eigenvectors().col(0).normalized();
    return up.dot(e.mean_image_up) < 0 ? Eigen::Vector3d(-up) : up;
  };
  std::vector<Eigen::Vector3d> xs;
  for (const auto& c : cameras) xs.push_back(c.cam_from_world.rotation.row(0).transpose());
  e.level = normal_to(xs);
  if (e.level) {
    const double limit = std::sin(15.0 * kPi / 180);
    std::vector<Eigen::Vector3d> level_xs;
    for (const auto& x : xs)
      if (std::abs(x.dot(*e.level)) <= limit) level_xs.push_back(x);
    if (level_xs.size() < xs.size()) {
      const auto again = normal_to(level_xs);
      if (again) {
        e.level = again;
        e.rolled = int(xs.size() - level_xs.size());
      }
    }
  }
  return e;
}

Eigen::Vector3d DeriveUp(const std::vector<Camera>& cameras, double snap_deg, double* spread_deg) {
  const UpEstimates e = EstimateUp(cameras);
  if (e.mean_image_up.isZero())
    throw std::invalid_argument(
        "the cameras' image-up directions cancel out (cameras rolled every way): state the world's up in the rig "
        "file (world: {up: [x, y, z]})");
  Eigen::Vector3d up = e.level ? *e.level : e.mean_image_up;
  int axis = 0;
  up.cwiseAbs().maxCoeff(&axis);
  Eigen::Vector3d snapped = Eigen::Vector3d::Zero();
  snapped(axis) = up(axis) > 0 ? 1 : -1;
  if (AngleDeg(up, snapped) <= snap_deg) up = snapped;
  if (spread_deg) {
    *spread_deg = 0;
    for (const auto& c : cameras)
      *spread_deg = std::max(*spread_deg, AngleDeg(-c.cam_from_world.rotation.row(1).transpose(), up));
  }
  return up;
}

Aabb CommonViewWorkspace(const std::vector<Camera>& cameras) {
  std::vector<cv::Mat> full;
  for (const auto& c : cameras) full.emplace_back(c.height, c.width, CV_8UC1, cv::Scalar(255));
  return HullBoundingBox(cameras, full, DefaultWorkspace(cameras));
}

double FramingRadius(const Aabb& box, double hfov_deg) {
  if (box.empty()) return 3.0;
  const double half_diagonal = 0.5 * (box.max - box.min).norm();
  return 1.1 * half_diagonal / std::tan(0.5 * hfov_deg * kPi / 180.0);
}

Eigen::Matrix3d StageAxes(const Eigen::Vector3d& up_in) {
  const Eigen::Vector3d up = up_in.normalized();
  int axis = 0;
  up.cwiseAbs().minCoeff(&axis);
  const Eigen::Vector3d unit = Eigen::Vector3d::Unit(axis);
  const Eigen::Vector3d x = (unit - unit.dot(up) * up).normalized();
  Eigen::Matrix3d r;
  r.col(0) = x;
  r.col(1) = up.cross(x);
  r.col(2) = up;
  return r;
}

Rigid3d StageFrame(const RigWorld& world, const Aabb& workspace) {
  const Eigen::Vector3d up = world.up.normalized();
  const Eigen::Vector3d centre = workspace.empty() ? Eigen::Vector3d::Zero() : workspace.Center();
  double floor_h = 0;
  if (world.floor == RigWorld::Floor::kPlane) {
    floor_h = world.floor_height;
  } else if (!workspace.empty()) {
    floor_h = up.dot(workspace.Corners()[0]);
    for (const auto& p : workspace.Corners()) floor_h = std::min(floor_h, up.dot(p));
  }
  Rigid3d world_from_stage;
  world_from_stage.rotation = StageAxes(up);
  world_from_stage.translation = centre - (up.dot(centre) - floor_h) * up;
  return world_from_stage;
}

RigReport CheckRig(const std::vector<Camera>& cameras, const Aabb& workspace, const RigWorld& world) {
  RigReport r;
  // The centre of what every camera sees within the workspace (the workspace's
  // own centre when that is empty).
  r.common_view = CommonViewWorkspace(cameras);
  Aabb seen = r.common_view;
  if (!seen.empty() && !workspace.empty()) {
    seen.min = seen.min.cwiseMax(workspace.min);
    seen.max = seen.max.cwiseMin(workspace.max);
  }
  r.workspace_centre = !seen.empty() ? seen.Center() : workspace.empty() ? LookAtPoint(cameras) : workspace.Center();
  if (workspace.empty())
    r.warnings.push_back("the cameras share no view (no point is in front of all of them and inside every image): "
                         "a visual hull of all of them is empty");
  const Eigen::Vector3d look_at = LookAtPoint(cameras);
  std::vector<int> blind;
  for (const auto& c : cameras) {
    CameraReport cr;
    cr.id = c.id;
    cr.centre = c.Center();
    cr.view_dir = ViewDir(c);
    cr.hfov_deg = Deg(std::atan((c.cx) / c.fx) + std::atan((c.width - c.cx) / c.fx));
    cr.vfov_deg = Deg(std::atan((c.cy) / c.fy) + std::atan((c.height - c.cy) / c.fy));
    const auto uv = c.Project(r.workspace_centre);
    cr.sees_centre = uv && c.InImage(*uv);
    if (!cr.sees_centre) blind.push_back(c.id);
    // Looking away from the others: the point the cameras look at is more than
    // 60 degrees off this camera's axis (and the others agree on it).
    if (cameras.size() >= 3 && (look_at - cr.centre).norm() > 1e-9) {
      const double off = AngleDeg(cr.view_dir, look_at - cr.centre);
      if (off > 60)
        r.warnings.push_back("camera " + std::to_string(c.id) + " looks away from the others: its axis is " +
                             std::to_string(int(std::lround(off))) +
                             " degrees from the point the cameras look at " + Vec(look_at) +
                             " (a world_from_camera pose read as cam_from_world, or OpenGL axes taken as OpenCV's?)");
    }
    if (world.floor == RigWorld::Floor::kPlane && world.up.normalized().dot(cr.centre) < world.floor_height)
      r.warnings.push_back("camera " + std::to_string(c.id) + " is below the floor (" + world.FloorText() +
                           "): is up the wrong way round?");
    r.cameras.push_back(cr);
  }
  if (!blind.empty() && !workspace.empty()) {
    std::string ids;
    for (int id : blind) ids += (ids.empty() ? "" : ", ") + std::to_string(id);
    r.warnings.push_back("camera(s) " + ids + " do not see the workspace centre " + Vec(r.workspace_centre) +
                         (2 * blind.size() > cameras.size()
                              ? " (most cameras: a world_from_camera pose read as cam_from_world, OpenGL axes taken "
                                "as OpenCV's, or a workspace stated in other units?)"
                              : ""));
  }
  // The point nearest every optical axis: cameras that look at something look
  // at it; most not seeing it means their poses or axes are the wrong way.
  int blind_to_look_at = 0;
  for (const auto& c : cameras) {
    const auto uv = c.Project(look_at);
    blind_to_look_at += !(uv && c.InImage(*uv));
  }
  if (cameras.size() >= 3 && 2 * blind_to_look_at > int(cameras.size()))
    r.warnings.push_back(std::to_string(blind_to_look_at) + " of " + std::to_string(cameras.size()) +
                         " cameras do not see the point nearest all their optical axes " + Vec(look_at) +
                         ": a world_from_camera pose read as cam_from_world, or OpenGL axes taken as OpenCV's?");
  // Scale: a capture space is metres to tens of metres across.
  double spread = 0;
  for (const auto& a : cameras)
    for (const auto& b : cameras) spread = std::max(spread, (a.Center() - b.Center()).norm());
  if (cameras.size() >= 2) {
    if (spread > 200)
      r.warnings.push_back("the cameras are " + FormatMetres(spread) +
                           " m apart: is the calibration in millimetres? (import with --scale 0.001)");
    else if (spread < 0.005)
      r.warnings.push_back("the cameras are " + FormatMetres(spread) +
                           " m apart: is the calibration in kilometres or arbitrary units? (import with --scale)");
  }
  const UpEstimates estimates = EstimateUp(cameras);
  if (estimates.level && !estimates.mean_image_up.isZero()) {
    const double apart = AngleDeg(*estimates.level, estimates.mean_image_up);
    if (apart > 10)
      r.warnings.push_back("the up at right angles to the cameras' image x-axes " + Vec(*estimates.level) +
                           " and their mean image-up " + Vec(estimates.mean_image_up) + " are " +
                           std::to_string(int(std::lround(apart))) +
                           " degrees apart (cameras looking down from one side lean the mean; rolled cameras "
                           "tilt the other): the derived up takes the first; if neither is right, state "
                           "world: {up: [x, y, z]}");
  }
  try {
    double spread_deg = 0;
    const Eigen::Vector3d derived = DeriveUp(cameras, 10.0, &spread_deg);
    const double off = AngleDeg(world.up.normalized(), derived);
    if (off > 45)
      r.warnings.push_back("up " + Vec(world.up.normalized()) + " is " + std::to_string(int(std::lround(off))) +
                           " degrees from the cameras' mean image-up " + Vec(derived) +
                           ": is the world z-up where the file says z-down (or the other way)?");
  } catch (const std::invalid_argument&) {
    r.warnings.push_back("the cameras' image-ups cancel out (cameras rolled every way, or a world_from_camera pose "
                         "read as cam_from_world?): up cannot be checked against them");
  }
  return r;
}

}  // namespace hullpipe
