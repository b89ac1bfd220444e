#include "hullpipe/compositor.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "hullpipe/conventions.h"

namespace hullpipe {

cv::Mat Composite(const NovelView& view, const cv::Mat& hull_depth, const cv::Mat& hull_colour,
                  const std::vector<VirtualSphere>& spheres, const CompositeOptions& o,
                  cv::Mat* depth_out) {
  CV_Assert(hull_depth.type() == CV_32FC1 && hull_colour.type() == CV_8UC3);
  CV_Assert(hull_depth.cols == view.width && hull_depth.rows == view.height);
  CV_Assert(hull_colour.size() == hull_depth.size());
  cv::Mat out(view.height, view.width, CV_8UC3);
  cv::Mat depth(view.height, view.width, CV_32FC1);
  const Eigen::Matrix3d& R = view.world_from_eye.rotation;
  const Eigen::Vector3d O = view.world_from_eye.translation;
  const Eigen::Vector3d light = (-o.floor_normal + Eigen::Vector3d(0.3, 0.2, 0)).normalized() * -1.0;
  for (int r = 0; r < view.height; ++r) {
    for (int c = 0; c < view.width; ++c) {
      const Eigen::Vector3d D = R * view.EyeRay(c + 0.5, r + 0.5);  // eye z of D is 1
      float best = hull_depth.at<float>(r, c);
      cv::Vec3b colour = std::isfinite(best) ? hull_colour.at<cv::Vec3b>(r, c) : cv::Vec3b(0, 0, 0);
      if (!std::isfinite(best)) {
        // Sky: a vertical gradient.
        const double up = std::clamp(-D.normalized().dot(-o.floor_normal) * 0.5 + 0.5, 0.0, 1.0);
        colour = cv::Vec3b(cv::saturate_cast<uint8_t>(120 + 100 * up),
                           cv::saturate_cast<uint8_t>(90 + 60 * up), cv::saturate_cast<uint8_t>(60 + 30 * up));
      }
      if (o.draw_floor) {
        const double denom = o.floor_normal.dot(D);
        if (std::abs(denom) > 1e-12) {
          const double s = (o.floor_offset - o.floor_normal.dot(O)) / denom;
          if (s > 0 && s < best) {
            best = float(s);
            const Eigen::Vector3d f = O + s * D;
            // Checkers of 0.5 m in the floor plane's two world axes most in it.
            const Eigen::Vector3d a = o.floor_normal.unitOrthogonal(), b = o.floor_normal.cross(a);
            const bool odd = (int(std::floor(f.dot(a) * 2)) + int(std::floor(f.dot(b) * 2))) & 1;
            const double fade = std::exp(-0.08 * s);
            const cv::Vec3b base = odd ? cv::Vec3b(180, 180, 170) : cv::Vec3b(110, 110, 100);
            for (int k = 0; k < 3; ++k) colour[k] = cv::saturate_cast<uint8_t>(base[k] * (0.4 + 0.6 * fade));
          }
        }
      }
      for (const auto& sp : spheres) {
        const Eigen::Vector3d oc = O - sp.centre;
        const double A = D.squaredNorm(), B = oc.dot(D), C = oc.squaredNorm() - sp.radius * sp.radius;
        const double disc = B * B - A * C;
        if (disc < 0) continue;
        const double s = (-B - std::sqrt(disc)) / A;
        if (s <= 0 || s >= best) continue;
        best = float(s);
        const Eigen::Vector3d n = (O + s * D - sp.centre).normalized();
        const double shade = 0.3 + 0.7 * std::max(0.0, n.dot(light));
        const cv::Vec3b base = sp.colliding ? o.collide_colour : o.ball_colour;
        for (int k = 0; k < 3; ++k) colour[k] = cv::saturate_cast<uint8_t>(base[k] * shade);
      }
      out.at<cv::Vec3b>(r, c) = colour;
      depth.at<float>(r, c) = best;
    }
  }
  if (depth_out) *depth_out = depth;
  return out;
}

Rigid3d OrbitPath::WorldFromEye(double t) const {
  const Eigen::Vector3d u = up.normalized();
  const Eigen::Vector3d a = u.unitOrthogonal(), b = u.cross(a);
  const double ang = phase + 2 * M_PI * t / period;
  const Eigen::Vector3d eye = centre + radius * (std::cos(ang) * a + std::sin(ang) * b) + height * u;
  return LookAt(eye, centre, u);
}

}  // namespace hullpipe
