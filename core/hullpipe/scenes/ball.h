// Balls thrown under gravity against the visual hull and the floor (paper §4):
// detection by §4.1's box test then per-triangle volume queries, response by
// §4.2 (D_rec along V_rec so CP_obj reaches CP_hull, velocity reflected about
// N_hull). Settings come from the scene file's `balls` section (scene_config.h),
// a registered kind of scene element (scene_element.h).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hullpipe/collision/collision_response.h"
#include "hullpipe/collision/collision.h"
#include "hullpipe/geometry/mesh.h"
#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/scenes/scene_element.h"
#include "hullpipe/util/interrupt.h"

namespace hullpipe {

/// One thrown ball.
struct BallConfig {
  int id = 1;
  double radius = 0.12;
  Eigen::Vector3d start{2.0, 0.2, -1.2};
  Eigen::Vector3d target{0.35, 0.05, -1.0};
  double flight_time = 0.9;
  double restitution = 0.7;
  double rethrow_period = 4.0;
  int subdivisions = 2;
  /// start and target are world-frame offsets from the hull box's centre at each
  /// throw (a `frame: stage` scene, after PlaceInWorld); false: world points.
  bool relative_to_hull = false;
};

/// The scene file's `balls` (a list; `[]` for none): a kind of scene element
/// (scene_element.h) that a stage scene may hold (its start and target are then
/// offsets from the hull's box centre along the stage's axes).
struct BallsConfig final : SceneElementConfig {
  std::vector<BallConfig> balls;
  BallsConfig() = default;
  explicit BallsConfig(std::vector<BallConfig> b) : balls(std::move(b)) {}

  std::string Key() const override { return "balls"; }
  /// "2 ball(s)".
  std::string Describe() const override;
  /// Throws std::invalid_argument naming the field: radius > 0, finite start and
  /// target, flight_time > 0, restitution and subdivisions in range, at most
  /// kMaxBalls balls and kMaxBallTriangles triangles together (limits.h).
  void CheckIn(const SceneConfig& scene) const override;
  std::unique_ptr<SceneElement> Make(const SceneConfig& scene) const override;
  /// One id per ball ("ball 2").
  std::vector<ObjectIdRange> ObjectIds() const override;
  bool CanBeOnStage() const override { return true; }
  /// Start and target turned into the world's axes by world_from_stage's
  /// rotation, and marked relative_to_hull.
  std::shared_ptr<const SceneElementConfig> PlaceOnStage(const Rigid3d& world_from_stage) const override;
};

/// Reads the `balls` list (each ball's radius, start and target required; id
/// defaults to its place in the list from 1). Throws std::runtime_error naming
/// `path` and the key ("balls[1].radius").
std::shared_ptr<const SceneElementConfig> ReadBallsSection(const YAML::Node& section, const std::string& path);

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
  /// `balls` in `scene`'s world (gravity, floor, collision and response
  /// settings, max_substep). Throws std::invalid_argument if either fails its
  /// check.
  BallSimulation(SceneConfig scene, BallsConfig balls);
  /// The scene's own balls (none if it has no `balls`).
  explicit BallSimulation(const SceneConfig& scene);
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
  BallsConfig balls_;
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
  BallsElement(const SceneConfig& scene, const BallsConfig& balls) : sim_(scene, balls) {}
  void Step(const StepContext& s) override { sim_.Step(s.dt, s.hull, s.stop, s.hull_motion); }
  void Output(double source_time_s, uint64_t frame_seq, ElementOutput* out) override;
  const BallSimulation& simulation() const { return sim_; }

 private:
  BallSimulation sim_;
};

}  // namespace hullpipe
