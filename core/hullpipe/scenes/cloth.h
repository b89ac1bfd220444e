// A cloth curtain hanging from a rod that real objects push aside (paper §4,
// "a virtual curtain"). World metres and seconds, world frame of the rig.
//
// Model: position-based dynamics (Müller et al. 2007), the simplest that looks
// right for a curtain: a grid of nx x ny particles, the top row pinned to the rod;
// structural (row and column), shear (both diagonals) and bending (two apart)
// distance constraints, projected `iterations` times per substep (Gauss–Seidel),
// velocity damping. The 20 x 18 cells give the paper's 720 triangles.
//
// Collision with the visual hull (paper §4.1–4.2): the cloth mesh is tested as the
// paper tests any virtual object — bounding boxes first, then every triangle
// volume-queried in its own viewport (DetectCollisions). The vertices of the
// colliding triangles, and every vertex that a point query puts inside, get the
// response with the *constrained* recovery vector the paper gives for cloth: a
// vertex moves along its own normal (V_rec, toward whichever side of the cloth
// reaches the hull's surface sooner; on a tie, the side it came from),
// to where that line leaves the hull (CP_hull, PushOutAlong) plus `clearance`.
// Constraints are projected before the response, so a step ends
// with every movable vertex outside the hull (pinned rod vertices excepted).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "hullpipe/geometry/mesh.h"
#include "hullpipe/collision/triangle_query.h"
#include "hullpipe/reconstruction/volume_query.h"
#include "hullpipe/scenes/limits.h"
#include "hullpipe/scenes/scene_element.h"
#include "hullpipe/util/interrupt.h"

namespace hullpipe {

/// Settings of a cloth curtain (scene file key `cloth`; a scene element:
/// scene_element.h).
struct ClothConfig final : SceneElementConfig {
  int id = 100;                                   ///< Object id in messages.
  Eigen::Vector3d rod_a{0.0, -0.6, -1.8};         ///< Rod ends, world metres (top corners).
  Eigen::Vector3d rod_b{0.0, 0.6, -1.8};
  double length = 1.2;                            ///< Hanging length along gravity, metres.
  int nx = 21, ny = 19;                           ///< Vertices along the rod and down (>= 2 each).
  int iterations = 8;                             ///< Constraint projections per substep.
  double damping = 0.02;                          ///< Velocity fraction lost per substep.
  double max_substep = 1.0 / 120.0;               ///< Longest substep, seconds.
  double clearance = 0.002;                       ///< Distance kept from the hull's surface, metres.
  double max_search = 0.6;                        ///< Longest CP_hull search along a normal, metres.
  TriangleQueryOptions collision{0.01, 0, 16};    ///< Viewports of the cloth's triangles (1 cm pixels).
  /// Throws std::invalid_argument naming the bad field.
  void Check() const;

  std::string Key() const override { return "cloth"; }
  std::string Describe() const override { return "a curtain"; }
  /// Check(), and a non-zero gravity (the curtain needs a down direction).
  void CheckIn(const SceneConfig& scene) const override;
  std::vector<ObjectIdRange> ObjectIds() const override { return {{id, id, "cloth"}}; }
  /// A ClothSimulation under the scene's gravity, published as a VirtualMesh
  /// of kind cloth with its colliding triangles.
  std::unique_ptr<SceneElement> Make(const SceneConfig& scene) const override;
};

/// Reads a scene file's `cloth` section (keys as ClothConfig's; rod_a, rod_b and
/// length required). Throws std::runtime_error naming the file and key.
std::shared_ptr<const SceneElementConfig> ReadClothSection(const YAML::Node& section, const std::string& path);

/// What a cloth step did (FCL-style result).
struct ClothStepStats {
  int colliding_triangles = 0;  ///< Triangles with collision points (last substep).
  int vertices_moved = 0;       ///< Vertices given the §4.2 response (all substeps).
  int vertices_left_inside = 0; ///< Movable vertices still inside after the last substep.
};

/// Deterministic: the same steps with the same hulls give the same positions.
class ClothSimulation {
 public:
  /// Builds the hanging, resting grid. Throws std::invalid_argument if the config
  /// fails Check() or gravity is zero (the curtain needs a down direction).
  ClothSimulation(const ClothConfig& config, const Eigen::Vector3d& gravity);
  /// Advances by dt seconds (clamped to [0, 0.25]) in substeps of at most
  /// max_substep, each checked against `hull` (nullptr: no hull). Throws
  /// Interrupted (util/interrupt.h) between substeps once `stop` is set.
  ClothStepStats Step(double dt, const VolumeQuery* hull, StopFlag stop = nullptr);
  /// The current mesh, world metres; triangles(): 2 (nx-1)(ny-1), CCW seen from
  /// the side the gravity-cross-rod normal points to.
  TriangleMesh Mesh() const;
  const std::vector<Eigen::Vector3d>& positions() const { return x_; }
  /// Per triangle: 1 if it had collision points in the last substep.
  const std::vector<uint8_t>& colliding() const { return colliding_; }
  bool pinned(size_t vertex) const { return inv_mass_[vertex] == 0; }
  /// Unit vertex normals of the current mesh (area-weighted).
  std::vector<Eigen::Vector3d> VertexNormals() const;
  const ClothConfig& config() const { return config_; }

 private:
  struct Constraint {
    int i, j;
    double rest;
  };
  int Index(int ix, int iy) const { return iy * config_.nx + ix; }
  void Respond(const VolumeQuery& hull, const std::vector<Eigen::Vector3d>& previous, ClothStepStats* stats);

  ClothConfig config_;
  Eigen::Vector3d gravity_;
  std::vector<Eigen::Vector3d> x_, v_;
  std::vector<double> inv_mass_;
  std::vector<Constraint> constraints_;
  std::vector<Eigen::Vector3i> triangles_;
  std::vector<uint8_t> colliding_;
};

/// Moves point p out of the hull along the ray p + s dir (dir unit; the side to
/// leave toward): to the first point outside (marching 2 mm steps, then bisected
/// to 0.05 mm: the nearest exit, CP_hull of the constrained V_rec), then
/// `clearance` beyond it where that is outside too. Returns false (p unchanged)
/// if the ray does not leave the hull within max_search. A hull gap thinner than
/// 2 mm along the ray may be stepped over. The constrained response of paper
/// §4.2 for a point (a cloth vertex or a particle).
bool PushOutAlong(const VolumeQuery& hull, const Eigen::Vector3d& dir, double clearance, double max_search,
                  Eigen::Vector3d* p);

}  // namespace hullpipe
