// Scene files (paper §4–§5): the schema of every hybrid scene sim_node and
// render_node read. The scene-wide settings are here; every element (the balls,
// cloth, particles, payload, models) is a registered kind of scene element
// (scene_element.h, scene_elements.cc) read from its own section. The balls'
// simulation is ball.h: balls thrown under gravity that collide with the visual
// hull and the floor. Collision detection is the paper's (§4.1: box test,
// then each triangle volume-queried in its own viewport); the response is §4.2's:
// the ball moves by D_rec along V_rec (plus 1 mm) so its deepest collision point
// CP_obj reaches the hull's surface at CP_hull, and its velocity is reflected about
// N_hull -- relative to the hull surface's own normal velocity there, from the
// previous frameset's hull (`hull_velocity`, on by default), so a moving hand
// throws what it strikes. `response: exact` (default) refines CP_obj below the viewport pixel and
// finds CP_hull and N_hull exactly (collision.h, collision_response.h); `paper`
// uses the paper's isosceles-triangle scans.
//
// Scene file (YAML), metres and seconds, world frame of the rig:
//   gravity: [0, 0, 9.81]         # Utrecht rig: z points down
//   floor: 0.0                    # floor plane: g_hat . x = floor (omit: no floor)
//   collision: {max_pixel_size: 0.004, fixed_viewport: 0, max_viewport: 32}
//   response: exact               # exact | paper
//   hull_velocity:                # the hull surface's motion at contacts (hull_motion.h)
//     {enabled: true, max_speed: 10, max_interval: 0.1}   # m/s (clamped beyond), s
//   balls:
//     - id: 1
//       radius: 0.12
//       start: [2.0, 0.2, -1.2]
//       target: [0.35, 0.05, -1.0]  # thrown to pass here after flight_time
//       flight_time: 0.9
//       restitution: 0.7
//       rethrow_period: 4.0         # rethrown from start every period (0: never)
//       subdivisions: 2             # icosphere level: 320 triangles
//   cloth:                          # optional curtain (cloth.h); keys as ClothConfig
//     {id: 100, rod_a: [..], rod_b: [..], length: 1.2, nx: 21, ny: 19, iterations: 8,
//      damping: 0.02, clearance: 0.002, max_pixel_size: 0.01}
//   particles:                      # optional stream (particles.h); keys as ParticleConfig
//     {id: 200, emitter: [..], emitter_radius: 0.05, velocity: [..], velocity_jitter: 0.1,
//      rate: 2000, max_particles: 4000, lifetime: 3, restitution: 0.2, friction: 0.3,
//      radius: 0.006, seed: 7}
//   payload:                        # optional §5.2 task (payload.h); keys as PayloadConfig
//     {first_id: 300, pmt_centre: [..], pmt_half: [..], axis: 1, direction: 1,
//      spacing: 0.14, a_half: [..], shaft_radius: 0.03, shaft_length: 0.25,
//      max_clearance: 0.15}
//   models:                         # optional CAD models (model_scene.h, docs/models.md)
//     - {file: engine.glb, units: mm, up: +y, anchor: bottom, position: [..], yaw_deg: 0,
//        warn_distance: 0.05, max_clearance: 0.1}
//   light:                          # optional virtual light with shadows (lighting.h),
//     {position: [..], target: [..], fov_deg: 70, map_size: 192, planes: 48, refine: 6,
//      bias: 0.02, ambient: 0.45, hull_diffuse: 0.5}   # read by render_node
//   balls: []                       # no balls
//
// Scenes for any rig (`frame: stage`): the balls' start and target are offsets
// in metres from the centre of the hull's box at each throw (so they reach
// whoever is there), along the rig's stage axes (rig_world.h StageFrame: z up,
// x and y horizontal); gravity is in the same axes (default [0, 0, -9.81]); the
// floor is the rig's (`world: floor`: a plane, under the first hull, or none), so
// `floor` is refused. A ball waits for a hull before its first throw. Models
// are placed in the stage frame (rig_world.h StageFrame: origin on the floor
// below the workspace's centre; model_scene.h). Cloth, particles, payload and
// light stay in world coordinates: refused in a stage scene (their geometry is
// the world's). sim_node --rig gives the world and the workspace;
// SceneConfig::PlaceInWorld applies them.
//
// Checked where read (LoadSceneConfig): the file is a non-empty map; every key
// is one of the above (a misspelt key is an error naming it, never ignored);
// `balls` is required (`[]` for none), and so are a ball's radius, start and
// target, the cloth's rod_a, rod_b and length, the particles' emitter and
// velocity, the light's position and target. Bounds: max_substep (scene, cloth,
// particles) in [1e-4, 0.1] s (limits.h); the rest as each Config::Check says.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hullpipe/collision/collision.h"
#include "hullpipe/geometry/rig_world.h"
#include "hullpipe/scenes/lighting.h"
#include "hullpipe/scenes/scene_element.h"

namespace hullpipe {

/// Scene settings; see the file format above.
struct SceneConfig {
  Eigen::Vector3d gravity{0, 0, 9.81};
  bool has_floor = true;
  double floor = 0.0;
  TriangleQueryOptions collision{0.004, 0, 32};
  /// How the §4.2 response is found: exact (RefineFarthestCollisionPoint +
  /// ComputeResponse) or paper (ComputeResponsePaper).
  enum class Response { kExact, kPaper } response = Response::kExact;
  /// The hull's motion at contacts (hull_motion.h): sim_node gives the elements
  /// the previous frameset's hull unless `enabled` is false.
  HullMotionOptions hull_velocity;
  /// Longest integration step (s), limits tunnelling; in [kMinSubstepS, kMaxSubstepS].
  double max_substep = 0.01;
  /// Every element (balls, cloth, particles, payload, models), in the order of
  /// SceneElementKinds(), at most one of each kind. Shared and immutable: a
  /// change replaces the element's settings (Set). None by default (see
  /// DefaultScene).
  std::vector<std::shared_ptr<const SceneElementConfig>> elements;
  std::optional<LightConfig> light;         ///< A virtual light casting shadows (render_node).
  /// `frame`: world (the rig's coordinates) or stage (see above).
  enum class Frame { kWorld, kStage } frame = Frame::kWorld;
  /// The floor goes under the first hull the scene sees (its lowest point along
  /// -gravity); set by PlaceInWorld for a rig whose floor is `hull`.
  bool floor_under_hull = false;
  /// A stage scene: turns its stage-axis vectors into the world's with `world`
  /// (StageAxes of its up), takes the rig's floor, marks the balls as
  /// hull-relative and places the elements that can be on the stage (models)
  /// by StageFrame(world, workspace) (an empty workspace: the stage's origin
  /// is the world's origin on the floor); frame becomes kWorld. A world scene:
  /// unchanged. Throws std::invalid_argument if the stage gravity is not along
  /// -z.
  void PlaceInWorld(const RigWorld& world, const Aabb& workspace = {});
  /// A floor_under_hull scene given a hull with a box: the floor becomes
  /// g_hat . x = the hull's lowest point along gravity (HullExtentAlong; g_hat
  /// +z without gravity), has_floor is set and floor_under_hull cleared. Any
  /// other call changes nothing. Each simulation calls it on its own copy.
  void TakeFloorUnderHull(const VolumeQuery* hull);
  /// Throws std::invalid_argument naming the bad field (a stage scene with an
  /// element or a light, an element's own CheckIn).
  void Check() const;
  /// The element of settings type C (ClothConfig, ...), or nullptr.
  template <typename C>
  const C* Find() const {
    for (const auto& e : elements)
      if (const auto* c = dynamic_cast<const C*>(e.get())) return c;
    return nullptr;
  }
  /// Puts `config` in place of the element of its kind (its Key), or adds it
  /// where SceneElementKinds() orders it.
  void Put(std::shared_ptr<const SceneElementConfig> config);
  template <typename C>
  void Set(C config) {
    Put(std::make_shared<C>(std::move(config)));
  }
};

/// sim_node's scene when it is given no file: one ball (BallConfig's
/// defaults), gravity and floor as SceneConfig's.
SceneConfig DefaultScene();

/// Reads a scene file (and, unless `load` says not to, the model files it
/// names). Throws std::runtime_error naming the file and key (a ModelError,
/// model_import.h, for a bad model file).
SceneConfig LoadSceneConfig(const std::string& path, const SceneLoadOptions& load = {});

}  // namespace hullpipe
