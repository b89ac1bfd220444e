#include "hullpipe/reconstruction/stereo_views.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Geometry>

#include "hullpipe/util/csv.h"

namespace hullpipe {

namespace {
constexpr double kMaxAngle = 89.0 * M_PI / 180.0;
}  // namespace

void EyeFov::Check() const {
  const std::pair<const char*, double> angles[] = {{"left", left}, {"right", right}, {"up", up}, {"down", down}};
  for (const auto& [name, a] : angles)
    if (!(std::abs(a) < kMaxAngle))
      throw std::invalid_argument(std::string("fov ") + name + " must be finite and within (-89, 89) deg");
  if (!(left < right)) throw std::invalid_argument("fov left must be less than right");
  if (!(down < up)) throw std::invalid_argument("fov down must be less than up");
}

NovelView EyeView(const EyeFov& fov, int width, int height, const Rigid3d& world_from_eye) {
  fov.Check();
  if (width < 1 || height < 1 || width > 8192 || height > 8192)
    throw std::invalid_argument("an eye's image must be 1 to 8192 pixels each way");
  NovelView v;
  v.width = width;
  v.height = height;
  const double tl = std::tan(fov.left), tr = std::tan(fov.right), tu = std::tan(fov.up), td = std::tan(fov.down);
  v.fx = double(width) / (tr - tl);
  v.cx = -tl * v.fx;
  // OpenCV's y points down: the top edge (v = 0) is at y/z = -tan(up).
  v.fy = double(height) / (tu - td);
  v.cy = tu * v.fy;
  v.world_from_eye = world_from_eye;
  return v;
}

EyeFov FovOfView(const NovelView& view) {
  if (!(view.fx > 0) || !(view.fy > 0) || view.width < 1 || view.height < 1)
    throw std::invalid_argument("a view's fov needs positive fx, fy and size");
  const EyeFov fov{std::atan(-view.cx / view.fx), std::atan((view.width - view.cx) / view.fx),
                   std::atan(view.cy / view.fy), std::atan((view.cy - view.height) / view.fy)};
  fov.Check();
  return fov;
}

std::string ForEye(const std::string& base, ViewEye eye, char separator) {
  switch (eye) {
    case ViewEye::kLeft:
      return base + separator + "left";
    case ViewEye::kRight:
      return base + separator + "right";
    case ViewEye::kMono:
      break;
  }
  return base;
}

Rigid3d WorldFromEye(const Rigid3d& world_from_head, Eye eye, double ipd_m) {
  const double side = eye == Eye::kLeft ? -0.5 : 0.5;
  Rigid3d e = world_from_head;
  e.translation = world_from_head.translation + world_from_head.rotation * Eigen::Vector3d(side * ipd_m, 0, 0);
  return e;
}

void StereoOptions::Check() const {
  if (!(ipd_m >= 0.04 && ipd_m <= 0.09)) throw std::invalid_argument("--ipd must be in [0.04, 0.09] m");
  try {
    left.Check();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("--fov-left: ") + e.what());
  }
  try {
    right.Check();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("--fov-right: ") + e.what());
  }
  if (width < 1 || height < 1 || width > 8192 || height > 8192)
    throw std::invalid_argument("--width and --height must be 1 to 8192 pixels");
}

StereoViews MakeStereoViews(const Rigid3d& world_from_head, const StereoOptions& o) {
  StereoViews v;
  v.eye[0] = EyeView(o.left, o.width, o.height, WorldFromEye(world_from_head, Eye::kLeft, o.ipd_m));
  v.eye[1] = EyeView(o.right, o.width, o.height, WorldFromEye(world_from_head, Eye::kRight, o.ipd_m));
  return v;
}

Eigen::Matrix3d OpenXrAxesInOpenCv() { return Eigen::Vector3d(1, -1, -1).asDiagonal(); }

StereoViewTrack::StereoViewTrack(std::vector<Row> rows) {
  std::array<std::vector<TimedPose>, 2> poses;
  for (size_t i = 0; i < rows.size(); ++i) {
    const Row& r = rows[i];
    try {
      r.fov.Check();
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("row " + std::to_string(i) + ": " + e.what());
    }
    const int k = int(r.eye);
    poses[k].push_back({r.t, r.world_from_eye});
    fovs_[k].push_back({r.t, r.fov});
  }
  for (int k = 0; k < 2; ++k) {
    if (poses[k].empty()) throw std::invalid_argument(std::string("no row of the ") + (k ? "right" : "left") + " eye");
    poses_[k] = PoseTrack(std::move(poses[k]));
    std::stable_sort(fovs_[k].begin(), fovs_[k].end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  }
}

NovelView StereoViewTrack::At(double t, Eye eye, int width, int height) const {
  const int k = int(eye);
  const auto& f = fovs_[k];
  // The latest row at or before t (the first before the first row).
  auto it = std::upper_bound(f.begin(), f.end(), t, [](double x, const auto& p) { return x < p.first; });
  const EyeFov& fov = it == f.begin() ? f.front().second : std::prev(it)->second;
  return EyeView(fov, width, height, poses_[k].At(t));
}

Rigid3d EyePoseFromXr(const Eigen::Vector3d& position, const Eigen::Vector4d& xyzw) {
  if (!position.allFinite() || !xyzw.allFinite()) throw std::invalid_argument("eye pose not finite");
  const Eigen::Quaterniond q(xyzw[3], xyzw[0], xyzw[1], xyzw[2]);
  if (!(q.norm() > 1e-9)) throw std::invalid_argument("zero quaternion");
  Rigid3d X;
  X.rotation = q.normalized().toRotationMatrix() * OpenXrAxesInOpenCv();
  X.translation = position;
  return X;
}

Eigen::Vector4d XrOrientationOf(const Rigid3d& world_from_eye) {
  // diag(1, -1, -1) is its own inverse.
  const Eigen::Quaterniond q(Eigen::Matrix3d(world_from_eye.rotation * OpenXrAxesInOpenCv()));
  return {q.x(), q.y(), q.z(), q.w()};
}

StereoViewTrack LoadStereoViewTrack(const std::string& path) {
  std::vector<StereoViewTrack::Row> rows;
  for (const CsvRow& row : ReadNumericCsv(path, 13, "t,eye,px,py,pz,qx,qy,qz,qw,left,right,up,down")) {
    const auto& v = row.values;
    StereoViewTrack::Row r;
    r.t = v[0];
    if (v[1] != 0 && v[1] != 1)
      throw std::runtime_error(CsvWhere(path, row.line) + "eye must be 0 (left) or 1 (right)");
    r.eye = v[1] == 0 ? Eye::kLeft : Eye::kRight;
    try {
      r.world_from_eye = EyePoseFromXr(Eigen::Vector3d(v[2], v[3], v[4]), Eigen::Vector4d(v[5], v[6], v[7], v[8]));
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(CsvWhere(path, row.line) + e.what());
    }
    r.fov = {v[9], v[10], v[11], v[12]};
    try {
      r.fov.Check();
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(CsvWhere(path, row.line) + e.what());
    }
    rows.push_back(r);
  }
  try {
    return StereoViewTrack(std::move(rows));
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
}

}  // namespace hullpipe
