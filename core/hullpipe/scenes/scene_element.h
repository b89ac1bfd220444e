// One interface for everything sim_node simulates against the visual hull
// (paper §4–§5): a kind of scene element is its settings (read from its section
// of a scene file, checked, turned into a simulation) and the simulation (a step
// against a frameset's hull, then what to publish: states, collision reports,
// meshes, log lines). The thrown balls, the cloth curtain, the particle stream and the
// payload task are such kinds; a new kind is one module that implements these
// two classes and one line in scene_elements.cc (docs/architecture.md, "Adding
// a scene element").
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "hullpipe/collision/hull_motion.h"
#include "hullpipe/geometry/rigid3.h"
#include "hullpipe/pipeline/messages.h"
#include "hullpipe/reconstruction/volume_query.h"
#include "hullpipe/util/interrupt.h"

namespace YAML {
class Node;
}

namespace hullpipe {

struct SceneConfig;

/// A part's collision starting or ending in a step (the payload task's log, §5.2).
struct PartCollisionEvent {
  double source_time_s = 0;
  uint64_t frame_seq = 0;
  std::string part;
  bool starts = false;
  double spacing_m = 0;  ///< The payload spacing at the time (0 for other kinds).
};

/// What an element gives sim_node to publish after a step. The samples'
/// frame_seq and capture_time_ns are the caller's to fill (the frameset's).
struct ElementOutput {
  /// Rigid bodies drawn from their state alone (VirtualObjectState): spheres,
  /// boxes at a pose. A body of any other shape is a ModelPart sent once and
  /// moved by ModelState.
  std::vector<VirtualObjectSample> states;
  std::vector<CollisionReportSample> reports;  ///< §4.1 points and §4.2 response per body.
  std::vector<VirtualMeshSample> meshes;       ///< Meshes and point sets to draw (VirtualMesh).
  std::vector<PartCollisionEvent> events;      ///< Collisions starting or ending.
  std::vector<ModelPartSample> model_parts;    ///< CAD model geometry (ModelPart): given once, by the first Output.
  std::vector<ModelStateSample> model_states;  ///< CAD models' part states (ModelState).
  uint64_t colliding_bodies = 0;               ///< Rigid bodies (balls) colliding this step.
};

/// What one step gives every element of the scene (as FCL's request structs):
/// the time to advance, the frameset's hull, its motion and the stop flag.
struct StepContext {
  double dt = 0;                      ///< Seconds of source time to advance (>= 0).
  const VolumeQuery* hull = nullptr;  ///< The frameset's visual hull; nullptr: none this step.
  /// The hull's motion (hull_motion.h: this and the previous frameset's
  /// hulls), or nullptr (a stationary hull, the paper's §4.2). Elements with
  /// rigid bodies (balls, dynamic model parts) reflect their velocity relative
  /// to the moving surface; the rest ignore it. Valid while Step runs.
  const HullMotion* hull_motion = nullptr;
  /// Step throws Interrupted (util/interrupt.h) once it is set; nullptr: never.
  StopFlag stop = nullptr;
};

/// A running element of the scene. Deterministic: the same steps against the
/// same hulls give the same outputs.
class SceneElement {
 public:
  virtual ~SceneElement() = default;
  /// Advances by step.dt against step.hull. Throws Interrupted once step.stop
  /// is set; the element is then part-way through the step (good only for
  /// stopping).
  virtual void Step(const StepContext& step) = 0;
  /// Appends what the last step gives to publish; source_time_s and frame_seq
  /// are the frameset's (for events).
  virtual void Output(double source_time_s, uint64_t frame_seq, ElementOutput* out) = 0;
  /// Sets the payload spacing (SceneCommand SET_SPACING, metres); false when the
  /// element has no spacing. Throws std::invalid_argument (nothing changes) for a
  /// value it refuses.
  virtual bool SetSpacing(double /*spacing_m*/) { return false; }
};

/// Object ids [first, last] that an element's outputs carry, and what carries
/// them ("cloth", "models: engine.glb"), for the log line of a clash.
struct ObjectIdRange {
  int64_t first = 0, last = 0;
  std::string what;
};

/// One element's settings as its scene-file section gives them. Immutable once
/// read: a change (a new spacing) makes a new one.
class SceneElementConfig {
 public:
  virtual ~SceneElementConfig() = default;
  /// The section's key in a scene file ("cloth").
  virtual std::string Key() const = 0;
  /// For the log: "a curtain".
  virtual std::string Describe() const = 0;
  /// Throws std::invalid_argument naming the bad field (the scene-wide settings,
  /// gravity for instance, may be needed).
  virtual void CheckIn(const SceneConfig& scene) const = 0;
  /// The running element, in the scene's world (gravity, floor).
  virtual std::unique_ptr<SceneElement> Make(const SceneConfig& scene) const = 0;
  /// The object ids its states, meshes, parts and reports carry: render_node
  /// keys what it draws by object id, so SceneConfig::Check refuses two
  /// elements (or balls) sharing one.
  virtual std::vector<ObjectIdRange> ObjectIds() const = 0;
  /// Whether a `frame: stage` scene may hold this kind (scene_config.h); false:
  /// its geometry is the world's, refused in a stage scene.
  virtual bool CanBeOnStage() const { return false; }
  /// The settings with their stage-frame geometry placed in the world by
  /// world_from_stage (rig_world.h StageFrame); only for kinds that CanBeOnStage.
  virtual std::shared_ptr<const SceneElementConfig> PlaceOnStage(const Rigid3d& /*world_from_stage*/) const {
    return nullptr;
  }
};

/// How much of a scene file to load.
struct SceneLoadOptions {
  /// Import the model files a `models` section names (model_scene.h). False:
  /// read and check the section's keys only (render_node, which needs the
  /// light, and gets the models' geometry from sim_node; the scene fuzzer).
  bool import_models = true;
  /// Model imports end within 0.2 s of this flag being set and the load throws
  /// Interrupted (a node's SIGINT flag: it stops within a second even while a
  /// model imports); nullptr: never.
  StopFlag stop = nullptr;
};

/// A kind of element: the key of its section and how to read one. `read`
/// throws std::runtime_error naming the file (`path`) and the key.
struct SceneElementKind {
  std::string key;
  std::function<std::shared_ptr<const SceneElementConfig>(const YAML::Node& section, const std::string& path,
                                                          const SceneLoadOptions& load)>
      read;
  /// Every scene file names it (the balls: `balls: []` for none, so a file
  /// without the key does not get a default ball unasked).
  bool required = false;
};

/// Every kind a scene file may hold, in the order their sections are read and
/// their elements step and publish (scene_elements.cc: the one registration
/// per kind).
const std::vector<SceneElementKind>& SceneElementKinds();

}  // namespace hullpipe
