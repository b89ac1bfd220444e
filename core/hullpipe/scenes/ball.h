// Balls thrown under gravity against the visual hull and the floor (paper §4):
// detection by §4.1's box test then per-triangle volume queries, response by
// §4.2 (D_rec along V_rec so CP_obj reaches CP_hull, velocity reflected about
// N_hull). Settings come from the scene file (scene_config.h).
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "hullpipe/collision/collision_response.h"
#include "hullpipe/collision/collision.h"
#include "hullpipe/geometry/mesh.h"
#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/scenes/scene_element.h"
#include "hullpipe/util/interrupt.h"

namespace hullpipe {

/// State of one body after a step.
struct BodyState {
  int id = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< World metres.
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< World m/s.
  double radius = 0;
  bool colliding = false;  ///< Touched the hull during the last step.
  CollisionResult last_collision;  ///< Of the last substep that collided.
  /// The §4 response of that substep (paper §4.2; collision_response.h), if found.
  std::optional<CollisionResponse> last_response;
};

/// Deterministic simulation: the same steps with the same hulls give the same states.
class BallSimulation {
 public:
  explicit BallSimulation(SceneConfig config);
  /// Advances by dt seconds (clamped to [0, 0.25]) in substeps of at most
  /// max_substep and short enough that no ball moves more than its radius in one
  /// (so it cannot tunnel through a thin part of the hull), each checked against
  /// `hull` (nullptr: no hull this step). Throws Interrupted (util/interrupt.h)
  /// between substeps once `stop` is set. `motion` (optional): the hull's
  /// motion since the previous frameset (hull_motion.h), so a ball struck by a
  /// moving hull leaves with its velocity relative to the surface reflected.
  void Step(double dt, const VolumeQuery* hull, StopFlag stop = nullptr, const HullMotion* motion = nullptr);
  const std::vector<BodyState>& bodies() const { return bodies_; }
  /// The world-frame mesh of body i at its current position.
  TriangleMesh WorldMesh(size_t i) const;
  double time() const { return time_; }
  const SceneConfig& config() const { return config_; }

 private:
  void Throw(size_t i, const VolumeQuery* hull);
  SceneConfig config_;
  std::vector<TriangleMesh> meshes_;  // body frame
  std::vector<BodyState> bodies_;
  std::vector<double> next_throw_;
  std::vector<char> waiting_;  // a hull-relative ball not thrown yet: no hull so far
  double time_ = 0;
};

/// The balls as a scene element (scene_element.h): each ball published as a
/// VirtualObjectState and a CollisionReport (§4.1 triangles and points, §4.2
/// response) every step.
class BallsElement final : public SceneElement {
 public:
  explicit BallsElement(const SceneConfig& config) : sim_(config) {}
  void Step(const StepContext& s) override { sim_.Step(s.dt, s.hull, s.stop, s.hull_motion); }
  void Output(double source_time_s, uint64_t frame_seq, ElementOutput* out) override;
  const BallSimulation& simulation() const { return sim_; }

 private:
  BallSimulation sim_;
};

}  // namespace hullpipe
