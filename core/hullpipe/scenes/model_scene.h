// A lab's own CAD models in the scene (paper §5: "a virtual model of a car
// engine", the payload's "CAD models of the PMT"), collided with the visual hull
// part by part (§4.1 through a bounding volume hierarchy per part:
// models/part_bvh.h) with each part's clearance from the hull (§4.5), drawn
// amber when the hull comes within warn_distance and red on contact. A part is
// one node of the file (models/model_import.h). Geometry is published once
// (ModelPart), each frameset only the parts' poses and contact states
// (ModelState).
//
// Scene file (docs/models.md), a list; world metres, the world of the rig:
//   models:
//     - file: /usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb
//       units: mm            # m | cm | mm | in; or scale: (metres per file unit).
//                            # glTF is metres by its spec (units: m by default);
//                            # STL, OBJ, PLY and others carry none: required.
//       up: +y               # the file's up axis (+x -x +y -y +z -z); default +y
//                            # (glTF's by its spec), +z for STL and PLY
//       anchor: bottom       # the point put at `position`: origin (default), centre
//                            # (of the model's box) or bottom (centre of its lowest face)
//       position: [0.3, 0.1, 0.0]
//       yaw_deg: 90          # turn about the world's up after the up axis is aligned
//       motion: static       # static: the parts stay put; dynamic: each part is a
//                            # rigid body of its own under gravity, on the floor,
//                            # pushed by the hull with §4.2's response as the balls
//                            # are (translation; orientation kept as placed)
//       restitution: 0.3     # dynamic parts: of the normal velocity, hull and floor
//       first_id: 1000       # object ids: first_id + part index (default 1000, then
//                            # each model after the last id of the one before)
//       warn_distance: 0.05  # amber within this of the hull, metres (0: never amber)
//       max_clearance: 0.1   # clearance measured up to this, metres (>= warn_distance)
//       max_pixel_size: 0.004  # the triangle query's viewport pixel, metres
// The world's up is -gravity. In a `frame: stage` scene (scene_config.h) the
// position, up and yaw are the stage's (rig_world.h StageFrame: origin on the
// floor below the workspace's centre, z up, yaw from the stage's x axis), so one
// scene file places the model on any rig. Caps (refused naming the cap): a file
// over 256 MiB, more than 5,000,000 triangles in the scene's models together,
// more than 200,000 in a dynamic model (its parts are queried every substep),
// an import that takes more than 4 GiB of memory or 60 s.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hullpipe/geometry/mesh.h"
#include "hullpipe/geometry/rigid3.h"
#include "hullpipe/models/model_import.h"
#include "hullpipe/models/part_bvh.h"
#include "hullpipe/scenes/scene_element.h"

namespace hullpipe {

/// Scene-wide caps on models (docs/models.md).
constexpr int64_t kMaxSceneModelTriangles = 5'000'000;
constexpr int64_t kMaxModelFileBytes = int64_t(256) << 20;
constexpr int64_t kMaxDynamicModelTriangles = 200'000;
/// Parts of a scene's models together (ImportLimits::max_parts).
constexpr int64_t kMaxSceneModelParts = 4096;
/// `scale` (metres per file unit) lies in [kMinModelScale, kMaxModelScale]
/// (a micrometre to a kilometre per unit), and every placed vertex within
/// kMaxStatedExtentM (10 km) of the world's origin: a scale of 1e308 once gave
/// non-finite vertices that render refused while every node exited 0.
constexpr double kMinModelScale = 1e-6, kMaxModelScale = 1e3;

/// One part ready to collide. A static part collides in the world: its mesh
/// and hierarchy are built there once. A dynamic part's mesh and hierarchy stay
/// in its body frame (the model's, scaled to metres) and world_from_body moves
/// them. `body` keeps the vertices in the body frame to send once.
struct ScenePart {
  std::string name;
  bool dynamic = false;
  TriangleMesh mesh;         ///< World metres (static parts), body metres (dynamic).
  TriangleBvh bvh;           ///< Over `mesh`.
  std::vector<Eigen::Vector3f> body;  ///< The vertices in the body frame, metres.
  cv::Vec3b colour;          ///< BGR.
  Rigid3d world_from_body;   ///< The part's pose (for a static part, the model's placement).
  /// What moves `mesh` into the world: identity (static) or world_from_body.
  Rigid3d world_from_mesh() const { return dynamic ? world_from_body : Rigid3d{}; }
};

/// One `models` entry.
struct ModelEntry {
  std::string file;          ///< As written in the scene file.
  std::string path;          ///< Resolved against the scene file's folder.
  double scale = 1.0;        ///< Metres per file unit.
  Eigen::Vector3d up_file = Eigen::Vector3d::UnitY();  ///< The file's up axis.
  enum class Anchor { kOrigin, kCentre, kBottom } anchor = Anchor::kOrigin;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< World metres.
  double yaw_deg = 0;
  enum class Motion { kStatic, kDynamic } motion = Motion::kStatic;
  double restitution = 0.3;  ///< Dynamic parts, in [0, 1].
  /// Set for a `frame: stage` scene (SceneConfig::PlaceInWorld): position, up
  /// and yaw are the stage's.
  std::optional<Rigid3d> world_from_stage;
  int first_id = 1000;
  double warn_distance = 0.05;
  double max_clearance = 0.1;
  double max_pixel_size = 0.004;
  /// The file as imported (null when the scene was read without importing).
  std::shared_ptr<const ImportedModel> imported;
  /// Throws std::invalid_argument naming the bad key.
  void Check() const;
};

/// The `models` section (a scene element: scene_element.h).
struct ModelsConfig final : SceneElementConfig {
  std::vector<ModelEntry> models;
  /// Threads of the triangle query and clearances (0: every core). One by
  /// default: on a machine that runs the other nodes too, threads of sim_node
  /// wait on cores those nodes hold (docs/benchmarks.md, "CAD models").
  int threads = 1;
  /// The triangle query of the models' collisions (sim_node --backend: the
  /// GL one on a GPU); empty: the CPU query on `threads` threads.
  TriangleQueryFunction query;
  std::string Key() const override { return "models"; }
  std::string Describe() const override;
  void CheckIn(const SceneConfig& scene) const override;
  /// Per model, first_id + each part (one id where the file was not imported).
  std::vector<ObjectIdRange> ObjectIds() const override;
  bool CanBeOnStage() const override { return true; }
  std::shared_ptr<const SceneElementConfig> PlaceOnStage(const Rigid3d& world_from_stage) const override;
  /// Each frameset: a dynamic model's parts moved in substeps (gravity, floor,
  /// and per substep their collision with the hull through the hierarchy and
  /// §4.2's response); a static model's parts' hierarchies descended against
  /// the hull and the surviving triangles of all parts queried in one batch
  /// (by `query`, else on the CPU across threads); each part's clearance. Outputs each model's
  /// ModelState, its ModelParts once, a CollisionReport per colliding part
  /// (with the response for dynamic parts), and collisions starting and ending
  /// as events.
  /// Throws std::invalid_argument if the models were not imported.
  std::unique_ptr<SceneElement> Make(const SceneConfig& scene) const override;
};

/// Reads a scene file's `models` section and (load.import_models) imports each
/// file (ImportModel: in a bounded child process) and places it. Throws
/// std::runtime_error naming the scene file and key, or ModelError naming the
/// model file.
std::shared_ptr<const SceneElementConfig> ReadModelsSection(const YAML::Node& section, const std::string& path,
                                                            const SceneLoadOptions& load);

/// The world_from_file transform of an entry: scale, up axis onto the world's up
/// (-gravity), yaw about it, anchor onto position; for an entry on the stage
/// (world_from_stage set) the same in the stage's frame (up its +z), then moved
/// by world_from_stage. `file_box`: the model's box in file units and frame.
Rigid3d ModelPlacement(const ModelEntry& entry, const Eigen::Vector3d& world_up, const Aabb& file_box);

/// Turns an imported model into placed parts with their hierarchies (metres;
/// the body frame is the file's, scaled): in the world for a static entry, in
/// the body frame for a dynamic one.
std::vector<ScenePart> PlaceModel(const ImportedModel& model, const ModelEntry& entry, const Eigen::Vector3d& world_up);

}  // namespace hullpipe
