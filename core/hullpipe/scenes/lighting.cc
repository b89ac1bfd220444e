#include "hullpipe/scenes/lighting.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "hullpipe/geometry/conventions.h"

namespace hullpipe {

void LightConfig::Check() const {
  if (!position.allFinite() || !target.allFinite() || (position - target).norm() < 1e-6)
    throw std::invalid_argument("light: position and target must be finite and distinct");
  if (!(fov_deg > 1 && fov_deg < 170)) throw std::invalid_argument("light: fov_deg must be in (1, 170)");
  if (map_size < 8 || map_size > 4096) throw std::invalid_argument("light: map_size must be in [8, 4096]");
  if (planes < 2) throw std::invalid_argument("light: planes must be >= 2");
  if (refine < 0 || refine > 20) throw std::invalid_argument("light: refine must be in [0, 20]");
  if (!(bias >= 0)) throw std::invalid_argument("light: bias must be >= 0");
  if (!(ambient >= 0 && ambient <= 1)) throw std::invalid_argument("light: ambient must be in [0, 1]");
  if (!(hull_diffuse >= 0 && hull_diffuse <= 1)) throw std::invalid_argument("light: hull_diffuse must be in [0, 1]");
}

NovelView LightView(const LightConfig& light, const Eigen::Vector3d& up) {
  return NovelView::FromFov(light.map_size, light.map_size, light.fov_deg * M_PI / 180.0,
                            LookAt(light.position, light.target, up));
}

bool ShadowMap::Shadowed(const Eigen::Vector3d& X, double bias) const {
  const Eigen::Vector3d e = eye_from_world * X;
  if (!(e.z() > 1e-6)) return false;
  const double u = view.fx * e.x() / e.z() + view.cx, v = view.fy * e.y() / e.z() + view.cy;
  if (!(u >= 0 && v >= 0 && u < view.width && v < view.height)) return false;
  return double(depth.at<float>(int(v), int(u))) < e.z() - bias;
}

cv::Mat HullDepthFromLight(const LightConfig& light, const Eigen::Vector3d& up, const VolumeQuery* hull,
                           int threads) {
  light.Check();
  const NovelView view = LightView(light, up);
  if (hull) {
    PlaneSweepOptions o;
    o.num_planes = light.planes;
    const auto depths = SweepPlaneDepths(*hull, view, o);
    if (!depths.empty())
      return PlaneSweepCpu(*hull, view, depths, cv::Rect(0, 0, view.width, view.height), nullptr, threads,
                           light.refine);
  }
  return cv::Mat(view.height, view.width, CV_32FC1, cv::Scalar(kNoDepth));
}

ShadowMap RenderShadowMap(const LightConfig& light, const Eigen::Vector3d& up, const VolumeQuery* hull,
                          const std::vector<VirtualSphere>& spheres, const MeshDraws& meshes,
                          int threads) {
  return RenderShadowMap(light, up, HullDepthFromLight(light, up, hull, threads), spheres, meshes);
}

ShadowMap RenderShadowMap(const LightConfig& light, const Eigen::Vector3d& up, const cv::Mat& hull_depth,
                          const std::vector<VirtualSphere>& spheres, const MeshDraws& meshes) {
  light.Check();
  ShadowMap s;
  s.view = LightView(light, up);
  s.eye_from_world = s.view.world_from_eye.Inverse();  // once, not per shadow test
  if (hull_depth.type() != CV_32FC1 || hull_depth.cols != s.view.width || hull_depth.rows != s.view.height)
    throw std::invalid_argument("RenderShadowMap: the hull's depth from the light must be CV_32FC1 " +
                                std::to_string(s.view.width) + "x" + std::to_string(s.view.height));
  // The virtual objects' depth from the light, nearest wins (the rasteriser of
  // Composite, without the floor: the floor receives shadows, casts none).
  CompositeOptions co;
  co.draw_floor = false;
  const cv::Mat black(s.view.height, s.view.width, CV_8UC3, cv::Scalar(0, 0, 0));
  Composite(s.view, hull_depth, black, spheres, co, &s.depth, meshes);
  return s;
}

void ApplyLighting(const NovelView& view, const cv::Mat& depth, const cv::Mat& hull_depth, const LightConfig& light,
                   const ShadowMap& shadow, cv::Mat* colour, StopFlag stop) {
  CV_Assert(depth.type() == CV_32FC1 && hull_depth.type() == CV_32FC1 && colour->type() == CV_8UC3);
  CV_Assert(depth.size() == colour->size() && hull_depth.size() == colour->size());
  const Eigen::Matrix3d& R = view.world_from_eye.rotation;
  const Eigen::Vector3d O = view.world_from_eye.translation;
  auto world = [&](int r, int c) {
    return Eigen::Vector3d(O + double(depth.at<float>(r, c)) * (R * view.EyeRay(c + 0.5, r + 0.5)));
  };
  for (int r = 0; r < view.height; ++r) {
    ThrowIfStopped(stop, "lighting");
    for (int c = 0; c < view.width; ++c) {
      const float z = depth.at<float>(r, c);
      if (!std::isfinite(z)) continue;
      const Eigen::Vector3d X = world(r, c);
      double f = shadow.Shadowed(X, light.bias) ? light.ambient : 1.0;
      const bool is_hull = hull_depth.at<float>(r, c) == z;
      if (is_hull && light.hull_diffuse > 0) {
        // The hull's normal from the depth's gradient (neighbours on the hull).
        const int c1 = c + 1 < view.width ? c + 1 : c - 1, r1 = r + 1 < view.height ? r + 1 : r - 1;
        if (c1 >= 0 && r1 >= 0 && std::isfinite(depth.at<float>(r, c1)) && std::isfinite(depth.at<float>(r1, c))) {
          Eigen::Vector3d n = (world(r, c1) - X).cross(world(r1, c) - X);
          if (n.norm() > 1e-12) {
            n.normalize();
            if (n.dot(O - X) < 0) n = -n;  // toward the viewer
            const double lambert = std::max(0.0, n.dot((light.position - X).normalized()));
            f *= (1.0 - light.hull_diffuse) + light.hull_diffuse * lambert;
          }
        }
      }
      if (f < 1.0) {
        cv::Vec3b& px = colour->at<cv::Vec3b>(r, c);
        for (int k = 0; k < 3; ++k) px[k] = cv::saturate_cast<uint8_t>(px[k] * f);
      }
    }
  }
}

}  // namespace hullpipe
