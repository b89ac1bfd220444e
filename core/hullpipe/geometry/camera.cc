#include "hullpipe/geometry/camera.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace hullpipe {

void Camera::Check() const {
  auto fail = [this](const std::string& what) {
    throw std::invalid_argument("camera " + std::to_string(id) + ": " + what);
  };
  if (width <= 0 || height <= 0 || width > kMaxSide || height > kMaxSide)
    fail("image size must be in [1, " + std::to_string(kMaxSide) + "] pixels");
  if (!(fx > 0) || !(fy > 0) || !std::isfinite(fx) || !std::isfinite(fy))
    fail("focal lengths must be finite and positive");
  if (!std::isfinite(cx) || !std::isfinite(cy)) fail("principal point must be finite");
  // |skew| <= fx: the image axes at least 45 degrees apart; published skews
  // are a few pixels at fx near 1000.
  if (!std::isfinite(skew) || !(std::abs(skew) <= fx)) fail("skew must be finite and at most fx in size");
  for (double d : distortion)
    if (!std::isfinite(d)) fail("distortion must be finite");
  const Eigen::Matrix3d& r = cam_from_world.rotation;
  if (!r.allFinite() || !cam_from_world.translation.allFinite())
    fail("cam_from_world must be finite");
  if ((r * r.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-6 ||
      std::abs(r.determinant() - 1.0) > 1e-6)
    fail("cam_from_world rotation must be orthonormal with det +1");
}

Eigen::Matrix3d Camera::K() const {
  Eigen::Matrix3d k;
  k << fx, skew, cx, 0, fy, cy, 0, 0, 1;
  return k;
}

Eigen::Vector3d Camera::Center() const {
  return -(cam_from_world.rotation.transpose() * cam_from_world.translation);
}

Eigen::Vector2d Camera::Undistort(const Eigen::Vector2d& xd) const {
  const auto& [k1, k2, p1, p2, k3] = distortion;
  if (!HasDistortion()) return xd;  // what the iteration below returns at once
  // Newton's method on Distort(x) = xd with the analytic Jacobian, from x = xd.
  // Quadratic convergence: ~1e-15 in a few steps even near the edge of the valid
  // radius, where OpenCV's fixed-point iteration is still 1e-5 px off.
  Eigen::Vector2d x = xd;
  for (int it = 0; it < 30; ++it) {
    const Eigen::Vector2d f = Distort(x) - xd;
    if (f.squaredNorm() < 1e-30) break;
    const double X = x.x(), Y = x.y(), r2 = X * X + Y * Y;
    const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double dradial = k1 + r2 * (2 * k2 + 3 * k3 * r2);  // d radial / d r2
    Eigen::Matrix2d J;
    J(0, 0) = radial + 2 * X * X * dradial + 2 * p1 * Y + 6 * p2 * X;
    J(0, 1) = 2 * X * Y * dradial + 2 * p1 * X + 2 * p2 * Y;
    J(1, 0) = J(0, 1);
    J(1, 1) = radial + 2 * Y * Y * dradial + 6 * p1 * Y + 2 * p2 * X;
    const double det = J.determinant();
    if (!(std::abs(det) > 1e-12)) break;  // at the fold: no unique inverse
    x -= J.inverse() * f;
    if (!x.allFinite()) return xd;
  }
  return x;
}

double Camera::MaxValidRadius2() const {
  if (const double cached = max_valid_radius2_.value.load(std::memory_order_relaxed); cached >= 0) return cached;
  // d/dr [r (1 + k1 r^2 + k2 r^4 + k3 r^6)] = 1 + 3 k1 r^2 + 5 k2 r^4 + 7 k3 r^6:
  // its first zero in s = r^2 (up to s = 100). Between the zeros of its own
  // derivative (a quadratic in s) it is monotonic, so the first interval whose
  // end is not positive holds the zero, found by bisection: exact, and a
  // slope that only touches zero is found too (a scan could step over it).
  const auto& d = distortion;
  const double a = 3 * d[0], b = 5 * d[1], c = 7 * d[4];
  auto slope = [&](double s) { return 1 + s * (a + s * (b + s * c)); };
  constexpr double kMaxS = 100.0;
  std::vector<double> ends;
  // Zeros of a + 2 b s + 3 c s^2.
  const double qa = 3 * c, qb = 2 * b, qc = a;
  if (qa == 0) {
    if (qb != 0) ends.push_back(-qc / qb);
  } else {
    const double disc = qb * qb - 4 * qa * qc;
    if (disc >= 0) {
      const double r = std::sqrt(disc);
      ends.push_back((-qb - r) / (2 * qa));
      ends.push_back((-qb + r) / (2 * qa));
    }
  }
  std::sort(ends.begin(), ends.end());
  std::erase_if(ends, [](double s) { return !(s > 0 && s < kMaxS); });
  ends.push_back(kMaxS);
  double result = std::numeric_limits<double>::infinity();
  double lo = 0;
  for (const double hi : ends) {
    if (slope(hi) <= 0) {
      double l = lo, h = hi;
      for (int i = 0; i < 200 && l < h; ++i) {
        const double mid = 0.5 * (l + h);
        if (mid <= l || mid >= h) break;
        (slope(mid) > 0 ? l : h) = mid;
      }
      result = l;
      break;
    }
    lo = hi;
  }
  max_valid_radius2_.value.store(result, std::memory_order_relaxed);
  return result;
}

std::optional<Eigen::Vector2d> Camera::Project(const Eigen::Vector3d& X_world) const {
  const Eigen::Vector3d xc = cam_from_world * X_world;
  if (!(xc.z() > 1e-9)) return std::nullopt;
  const Eigen::Vector2d xn(xc.x() / xc.z(), xc.y() / xc.z());
  if (xn.squaredNorm() > MaxValidRadius2()) return std::nullopt;
  // Distort with zero coefficients is the identity, bit for bit: skipped.
  const Eigen::Vector2d xd = HasDistortion() ? Distort(xn) : xn;
  return PixelFromImagePlane(xd);
}

Eigen::Vector3d Camera::PixelRayWorld(const Eigen::Vector2d& uv) const {
  const Eigen::Vector2d xn = Undistort(ImagePlaneFromPixel(uv));
  return (cam_from_world.rotation.transpose() * Eigen::Vector3d(xn.x(), xn.y(), 1.0))
      .normalized();
}

Camera ScaledCamera(const Camera& camera, int new_width, int new_height) {
  Camera c = camera;
  const double sx = double(new_width) / camera.width;
  const double sy = double(new_height) / camera.height;
  c.width = new_width;
  c.height = new_height;
  c.fx *= sx;
  c.skew *= sx;  // u scales by sx whatever y is
  c.fy *= sy;
  c.cx *= sx;  // continuous coordinates with +0.5 centres scale exactly
  c.cy *= sy;
  return c;
}

}  // namespace hullpipe
