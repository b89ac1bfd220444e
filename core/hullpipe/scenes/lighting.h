// Lighting and shadows between the real and the virtual (paper §4–§5):
// a virtual point light lights the hull and the virtual objects, and real objects
// (the hull) cast shadows on virtual ones (and on the floor and themselves);
// virtual objects cast shadows too. Shadow mapping: the scene's depth from the
// light's viewpoint, where the hull's part comes from the same volume-querying
// plane sweep that renders the user's view (PlaneSweepCpu, refined), and the
// virtual objects' part from the compositor's rasteriser. World metres.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "hullpipe/reconstruction/compositor.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe {

/// A virtual point light (scene file key `light`).
struct LightConfig {
  Eigen::Vector3d position{1.5, -1.0, -3.0};  ///< World metres.
  Eigen::Vector3d target{0.3, 0.0, -0.9};     ///< Where its shadow map looks.
  double fov_deg = 70;                        ///< Shadow map field of view.
  int map_size = 192;                         ///< Shadow map pixels across.
  int planes = 48;                            ///< Sweep planes of the hull's depth from the light.
  int refine = 6;                             ///< Bisections of each depth.
  double bias = 0.02;                         ///< Depth bias of the shadow test, metres.
  double ambient = 0.45;                      ///< Light that reaches a shadowed point (fraction).
  double hull_diffuse = 0.5;                  ///< How much the light's angle shades the hull's texture.
  /// Throws std::invalid_argument naming the bad field.
  void Check() const;
};

/// The light's view for its shadow map (an undistorted pinhole camera at the
/// light looking at its target, image up toward -gravity `up`).
NovelView LightView(const LightConfig& light, const Eigen::Vector3d& up);

/// A shadow map: eye-z depth (metres) of the nearest occluder seen from the light,
/// kNoDepth (+inf) where none.
struct ShadowMap {
  NovelView view;
  Rigid3d eye_from_world;  ///< view.world_from_eye inverted (RenderShadowMap sets both).
  cv::Mat depth;  ///< CV_32FC1, view size.
  /// True if the world point X is farther from the light than the occluder on its
  /// line of sight by more than `bias` (inside the map's frustum; outside it:
  /// lit).
  bool Shadowed(const Eigen::Vector3d& X_world, double bias) const;
};

/// The shadow map of the hull of `hull` (nullptr: none) and the given virtual
/// objects, seen from the light: RenderShadowMap of HullDepthFromLight.
ShadowMap RenderShadowMap(const LightConfig& light, const Eigen::Vector3d& up, const VolumeQuery* hull,
                          const std::vector<VirtualSphere>& spheres, const MeshDraws& meshes,
                          int threads = 1);

/// The hull's part of the shadow map: eye-z depth (metres) of the hull of `hull`
/// seen from the light (LightView(light, up)), by the plane sweep with the
/// light's planes and refinement on `threads` threads; kNoDepth (+inf) where
/// none, everywhere when `hull` is null or its box is not in the light's view.
/// CV_32FC1 of the light view's size. It needs only the frameset, so render_node
/// makes it while the recon nodes sweep, and adds the objects when its tiles are
/// in (its stage light_hull: docs/latency.md). Throws std::invalid_argument if
/// the light fails Check().
cv::Mat HullDepthFromLight(const LightConfig& light, const Eigen::Vector3d& up, const VolumeQuery* hull,
                           int threads = 1);

/// The shadow map of a hull depth from the light made by HullDepthFromLight (of
/// the same light and up) and the given virtual objects. Throws
/// std::invalid_argument if the light fails Check() or `hull_depth` is not
/// CV_32FC1 of the light view's size.
ShadowMap RenderShadowMap(const LightConfig& light, const Eigen::Vector3d& up, const cv::Mat& hull_depth,
                          const std::vector<VirtualSphere>& spheres, const MeshDraws& meshes);

/// Lights a composited view in place: every pixel with a surface (finite depth:
/// floor, hull, virtual objects) the light cannot see (ShadowMap::Shadowed) is
/// darkened to `ambient`; hull pixels (hull_depth finite and equal to the
/// composited depth) are also shaded by the angle between the light and the
/// hull's normal (from the composited depth's gradient). colour: CV_8UC3, depth:
/// CV_32FC1 eye z as Composite's depth_out, hull_depth as given to Composite.
/// `stop` is polled per row: once set, throws Interrupted with *colour part-lit.
void ApplyLighting(const NovelView& view, const cv::Mat& depth, const cv::Mat& hull_depth, const LightConfig& light,
                   const ShadowMap& shadow, cv::Mat* colour, StopFlag stop = nullptr);

}  // namespace hullpipe
