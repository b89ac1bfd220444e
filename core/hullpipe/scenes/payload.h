// The payload spacing task of paper §5.2: a virtual PMT box and payload A (a box
// with a central cylindrical shaft), a real pipe held by the user between them.
// Any part in collision with the hull is drawn red; each frame the least
// clearance between the hull and each part is measured; the spacing between the
// PMT and payload A can change while the system runs. World metres, frame of the
// rig; the parts are axis-aligned in the world frame.
//
// The paper's task used the payload's CAD models: the PMT and payload A may each
// be a model file instead of a box (`pmt_model`, `a_model`: a file, one of its
// parts or all of them, its units and a rotation into the world's axes), placed
// by its box as the box part would be, measured by its exact signed distance
// (models/mesh_distance.h; a mesh that bounds no volume: the distance to its
// surface, its collisions by the triangle query). A model payload A has no
// separate shaft (the model holds what it holds).
//
// Clearance (the least distance from any hull point to a part) is found from
// the parts' exact signed distances and volume queries: the hull is sampled on a
// grid (2 cm) over the part's box grown by `max_clearance`, and the inside sample
// nearest the part is refined three times on grids five times finer (4 mm,
// 0.8 mm, 0.16 mm) within two steps around it. The result is never below the
// true clearance of the hull and above it by at most half a finest-grid diagonal
// (0.14 mm), unless a hull part thinner than the coarse grid, or more than two
// coarse steps from the nearest coarse sample, lies nearer (then it is reported
// as found).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hullpipe/collision/collision.h"
#include "hullpipe/geometry/mesh.h"
#include "hullpipe/models/mesh_distance.h"
#include "hullpipe/reconstruction/volume_query.h"
#include "hullpipe/scenes/scene_element.h"

namespace hullpipe {

/// A part: an analytic, axis-aligned box or cylinder along a world axis, or a
/// model's mesh (world axes) whose box is centred on `centre`.
struct PayloadPart {
  std::string name;
  enum class Type { kBox, kCylinder, kMesh } type = Type::kBox;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d half_extents = Eigen::Vector3d::Constant(0.1);  ///< Box; a mesh's box.
  /// kMesh: the mesh, world axes, metres, its box centred on the origin.
  std::shared_ptr<const MeshSignedDistance> shape;
  int axis = 0;               ///< Cylinder axis: 0 x, 1 y, 2 z.
  double radius = 0.05;       ///< Cylinder radius.
  double half_length = 0.1;   ///< Cylinder half length along its axis.
  /// Exact signed distance (metres) from p to the part's surface, negative inside.
  double SignedDistance(const Eigen::Vector3d& p) const;
  /// A triangle mesh of the part (~2 cm triangles; cylinder with 24 sides).
  TriangleMesh Mesh() const;
  Aabb Bounds() const;
};

/// The PMT or payload A as a model file (scene keys `pmt_model`, `a_model`).
struct PayloadModel {
  std::string file;  ///< As the scene names it (relative to the scene file).
  std::string path;  ///< Where it was read.
  std::string part;  ///< The file's part (node) to take; "": every part, as one mesh.
  double scale = 1;  ///< Metres per file unit (`units` m, cm, mm, in, or `scale`; glTF: metres).
  /// The file's axes turned into the world's: about world x, then y, then z, degrees.
  Eigen::Vector3d rotation_deg = Eigen::Vector3d::Zero();
  /// The mesh in world axes and metres, its box centred on the origin; null
  /// when the scene was read without importing models (SceneLoadOptions).
  std::shared_ptr<const MeshSignedDistance> shape;
};

/// Most triangles of a payload model part (each is published whole every
/// frame as a VirtualMesh: at most 200,000 vertices).
constexpr int64_t kMaxPayloadModelTriangles = 100'000;

/// Settings of the task (scene file key `payload`; a scene element:
/// scene_element.h).
struct PayloadConfig final : SceneElementConfig {
  int first_id = 300;                                  ///< Object ids: PMT, payload A, shaft.
  Eigen::Vector3d pmt_centre{0.35, -0.35, -0.9};       ///< PMT box centre, world metres.
  Eigen::Vector3d pmt_half{0.15, 0.15, 0.15};          ///< PMT box half extents.
  int axis = 1;                                        ///< Spacing axis (0 x, 1 y, 2 z): payload A
  int direction = 1;                                   ///< lies on this side (+1 or -1) of the PMT.
  double spacing = 0.14;                               ///< Gap between PMT and payload A, metres.
  Eigen::Vector3d a_half{0.15, 0.10, 0.15};            ///< Payload A box half extents.
  double shaft_radius = 0.03;                          ///< Central shaft (far side of A), metres.
  double shaft_length = 0.25;
  std::optional<PayloadModel> pmt_model;               ///< The PMT as a model (pmt_half unused).
  std::optional<PayloadModel> a_model;                 ///< Payload A as a model (a_half and shaft unused).
  double max_clearance = 0.15;                         ///< Clearance searched up to this, metres.
  TriangleQueryOptions collision{0.004, 0, 32};        ///< Viewports of the parts' triangles.
  /// Throws std::invalid_argument naming the bad field.
  void Check() const;
  /// The parts at the current spacing: PMT, payload A, A's shaft (none when A
  /// is a model). A model's part is its mesh, placed as the box part would be
  /// with the model's box. Throws std::logic_error for a model not imported.
  std::vector<PayloadPart> Parts() const;
  /// PMT, payload A and the shaft: 3; 2 when A is a model.
  int PartCount() const { return a_model ? 2 : 3; }

  std::string Key() const override { return "payload"; }
  /// "the payload task" (with its models: "the payload task (PMT: engine.glb
  /// part 'piston')").
  std::string Describe() const override;
  void CheckIn(const SceneConfig& scene) const override;
  /// PMT, payload A, shaft.
  std::vector<ObjectIdRange> ObjectIds() const override {
    return {{first_id, first_id + PartCount() - 1, "payload"}};
  }
  /// The task evaluated each step (EvaluatePayload): each part published as a
  /// VirtualMesh of kind part (id first_id + k, drawn red whole while it
  /// collides) with its clearance, and each part's collision starting or ending
  /// as an event. Takes SetSpacing.
  std::unique_ptr<SceneElement> Make(const SceneConfig& scene) const override;
};

/// Reads a scene file's `payload` section (keys as PayloadConfig's; `pmt_model`
/// and `a_model` as {file, part, units | scale, rotation_deg}, imported unless
/// `load` says not to). Throws std::runtime_error naming the file and key (a
/// ModelError for a bad model file).
std::shared_ptr<const SceneElementConfig> ReadPayloadSection(const YAML::Node& section, const std::string& path,
                                                             const SceneLoadOptions& load = {});

/// Clearance of one part from the hull (FCL-style distance result).
struct ClearanceResult {
  double distance = 0;     ///< Metres; 0 when the hull touches or enters the part.
  bool colliding = false;  ///< Some hull sample lies inside the part.
  bool hull_near = false;  ///< Any hull within max_clearance (else distance = max_clearance).
  Eigen::Vector3d hull_point = Eigen::Vector3d::Zero();  ///< The hull sample nearest the part.
};

/// Least distance from the hull of `query` to `part` up to max_clearance (see the
/// file comment for the method and its error).
ClearanceResult HullClearance(const VolumeQuery& query, const PayloadPart& part, double max_clearance);

/// One frame of the task: per part, collision (paper §4.1 triangle queries) and
/// clearance.
struct PayloadFrame {
  std::vector<PayloadPart> parts;
  std::vector<CollisionResult> collisions;  ///< Per part.
  std::vector<ClearanceResult> clearance;   ///< Per part.
};

/// Evaluates the task against one frame's hull (nullptr: no hull, nothing collides).
PayloadFrame EvaluatePayload(const PayloadConfig& config, const VolumeQuery* hull);

/// One sample of a recorded pipe motion: the pipe as a capsule (segment p–q and
/// radius, world metres) at time t seconds.
struct PipePose {
  double t = 0;
  Eigen::Vector3d p = Eigen::Vector3d::Zero(), q = Eigen::Vector3d::Zero();
  double radius = 0.02;
};

/// Reads a motion CSV: `t,px,py,pz,qx,qy,qz,radius` per line (seconds, metres),
/// an optional header line, '#' comments (ReadNumericCsv's rules). Throws
/// std::runtime_error naming the file and line, also for a radius <= 0 or a
/// file with no rows.
std::vector<PipePose> LoadPipeMotion(const std::string& path);
/// Writes the same format. Throws std::runtime_error if the file cannot be written.
void SavePipeMotion(const std::string& path, const std::vector<PipePose>& motion);

/// A synthetic motion whose answer is known: the paper's pipe (14 cm long, 4 cm
/// across: a capsule) held across the gap, parallel to the PMT's face, moving
/// along the spacing axis from 1 cm off the PMT's face to `travel` beyond that and
/// back, `frames` samples over 2 s. *needed (optional) receives the smallest
/// spacing at which the true pipe never touches payload A: 1 cm + 4 cm + travel.
std::vector<PipePose> ExamplePipeMotion(const PayloadConfig& config, double travel, int frames,
                                        double* needed = nullptr);

/// Result of SweepSpacing.
struct SpacingSweepResult {
  struct Row {
    double spacing = 0;         ///< Metres.
    int frames_colliding = 0;   ///< Frames in which any part of payload A collides.
    double min_clearance = 0;   ///< Least clearance of payload A over the motion, metres.
  };
  std::vector<Row> rows;        ///< The spacing table, in increasing spacing.
  /// The smallest collision-free spacing, bisected to `resolution` between the
  /// last colliding and the first free table row; NaN if no row is free.
  double smallest_free = 0;
  int pmt_frames_colliding = 0; ///< The PMT does not move: its collisions hold at every spacing.
};

/// Replays one motion (a hull per frame) at spacings from..to step `step`
/// (metres) and finds the smallest at which payload A (box and shaft) never
/// collides (HullClearance <= 0), paper §5.2. Throws std::invalid_argument on a
/// bad range.
SpacingSweepResult SweepSpacing(const PayloadConfig& config, const std::vector<VolumeQuery>& hulls, double from,
                                double to, double step, double resolution = 0.001);

}  // namespace hullpipe
