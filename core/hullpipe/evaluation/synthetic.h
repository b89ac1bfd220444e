// Synthetic scenes with exact ground truth: analytic shapes seen by calibrated
// cameras. An object pixel is exactly a pixel whose centre ray hits a shape, so
// every algorithm can be measured against truth. The world frame mirrors the
// Utrecht rig: z points down, the floor is z = 0.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "hullpipe/geometry/camera.h"

namespace hullpipe {

/// One analytic solid. Lengths in world metres.
struct Shape {
  enum class Type { kSphere, kBox, kCapsule, kTorus };
  Type type = Type::kSphere;
  Eigen::Vector3d a = Eigen::Vector3d::Zero();  ///< Sphere/box centre; capsule end 1.
  Eigen::Vector3d b = Eigen::Vector3d::Zero();  ///< Capsule end 2.
  Eigen::Vector3d half_extents = Eigen::Vector3d::Constant(0.1);  ///< Box half sizes.
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< Box/torus: world_from_shape rotation.
  double radius = 0.1;                                      ///< Sphere/capsule radius; torus tube radius.
  double major_radius = 0.2;                                ///< Torus: centre to tube centre.
  cv::Vec3b colour{60, 60, 200};                            ///< BGR.

  static Shape Sphere(const Eigen::Vector3d& c, double r);
  static Shape Box(const Eigen::Vector3d& c, const Eigen::Vector3d& half,
                   const Eigen::Matrix3d& world_from_box = Eigen::Matrix3d::Identity());
  static Shape Capsule(const Eigen::Vector3d& p, const Eigen::Vector3d& q, double r);
  /// Torus centred at c, its axis the shape frame's z (world_from_torus rotation),
  /// ring radius R, tube radius r < R. A concave shape: its visual hull fills the hole
  /// only where no camera sees through it.
  static Shape Torus(const Eigen::Vector3d& c, double R, double r,
                     const Eigen::Matrix3d& world_from_torus = Eigen::Matrix3d::Identity());

  /// Signed distance (world metres) from p to the surface: negative inside.
  /// Exact (Euclidean) for every type.
  double SignedDistance(const Eigen::Vector3d& p) const;

  /// True if the world point is inside or on the solid.
  bool Contains(const Eigen::Vector3d& p) const;
  /// Smallest s >= 0 with origin + s * dir on the surface (dir need not be unit),
  /// or nullopt; a ray starting inside hits at s = 0. Closed form for sphere, box
  /// and capsule; the torus by sphere tracing its exact distance to 1e-10 m (a ray
  /// grazing the tube within that distance may be reported as a miss).
  std::optional<double> Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) const;
  /// Outward unit normal at a surface point.
  Eigen::Vector3d Normal(const Eigen::Vector3d& p) const;
};

/// A set of shapes at one instant.
struct SyntheticScene {
  std::vector<Shape> shapes;
  bool Contains(const Eigen::Vector3d& p) const;
  /// First hit along a ray over all shapes: {s, shape index}.
  std::optional<std::pair<double, int>> Intersect(const Eigen::Vector3d& origin,
                                                  const Eigen::Vector3d& dir) const;
};

/// The outward surface normal of the smooth visual hull of `scene` (the hull of
/// the exact, continuous silhouettes seen from camera centres `centres`, world
/// metres) at X, a point on or near it: the ground truth for N_hull (paper §4.2).
/// Each camera's generator line from its centre through X is searched for its
/// least signed distance to the scene (sampled every 2 mm, then refined by golden
/// section to 1e-7 m); the camera whose line comes closest to grazing (least
/// distance nearest zero) forms the surface there, and the normal is the scene's
/// normal at that tangent point, made perpendicular to the line. If a second
/// camera's line grazes within `edge_tolerance` metres of the first, X is on a
/// hull edge or corner where the normal is undefined: *on_edge is set (if given);
/// likewise if the scene's normal turns by more than 5 degrees within 2 mm of the
/// tangent point (a crease, e.g. a box's edge: the silhouette has a corner).
Eigen::Vector3d SmoothHullNormal(const SyntheticScene& scene, const std::vector<Eigen::Vector3d>& centres,
                                 const Eigen::Vector3d& X, double edge_tolerance = 5e-4, bool* on_edge = nullptr);

/// The built-in animated scene: a standing figure of capsules and a sphere head
/// whose right arm waves, at time t seconds (period 4 s). About 1.7 m tall, centred
/// at the world origin on the floor (z down).
SyntheticScene AnimatedFigure(double t_seconds);

/// A right hand and forearm as a chain of capsules (forearm, palm, five fingers of
/// two or three segments, ~1.5-2 cm thick) around `wrist`, opening and closing and
/// turning with period 3 s: fingers a few mm to cm apart, the hard case for a hull.
SyntheticScene HandAndForearm(double t_seconds, const Eigen::Vector3d& wrist = Eigen::Vector3d(0, 0, -1.0));

/// Synthetic evaluation scenes by name at time t: "sphere" (r 0.3 m), "box"
/// (0.5 x 0.3 x 0.2 m, turned), "torus" (R 0.25, r 0.08, tilted), "hand"
/// (HandAndForearm), "figure" (AnimatedFigure), "mixed" (sphere, box, torus and a
/// capsule). All but "figure" are centred near (0, 0, -1), 1 m above the floor.
/// Throws std::invalid_argument for another name.
SyntheticScene NamedScene(const std::string& name, double t_seconds);

/// A pinhole camera (id, w x h pixels, horizontal field of view hfov radians,
/// principal point at the image centre) at `eye` looking at `target` (world
/// metres), image up as close as possible to `up`.
Camera LookingCamera(int id, const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up,
                     int width, int height_px, double hfov, const Distortion& distortion = {});
/// n cameras spread over a dome (a hemisphere above `target`, elevations 15-70
/// degrees, golden-angle azimuths) of `radius`, all looking at target. Ids 1..n.
std::vector<Camera> DomeCameras(int n, double radius, const Eigen::Vector3d& target, int width, int height_px,
                                double hfov, const Distortion& distortion = {});

/// n cameras on a ring of `radius` around `target`, at height `height` above the
/// floor (world z = -height), all looking at target, image w x h with horizontal
/// field of view hfov (radians) and the given distortion. Ids 1..n.
std::vector<Camera> RingCameras(int n, double radius, double height, const Eigen::Vector3d& target,
                                int width, int height_px, double hfov, const Distortion& distortion = {});

/// Exact object-pixel map: pixel is 255 iff the ray through its centre (with lens
/// distortion undone) hits a shape. CV_8UC1 of the camera's size.
cv::Mat RenderExactMap(const Camera& camera, const SyntheticScene& scene);

/// Colour image: shapes shaded by a fixed light over a background of floor
/// checkers and a plain wall; the background alone when scene is empty. CV_8UC3.
cv::Mat RenderColour(const Camera& camera, const SyntheticScene& scene);

}  // namespace hullpipe
