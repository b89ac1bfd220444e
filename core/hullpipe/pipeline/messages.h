// The pipeline's samples as the node controllers see them: plain structs of
// OpenCV and Eigen types, DDS-free and free of every algorithm, so the DDS layer,
// the recorder and the tools can depend on them without linking any
// (docs/architecture.md, "Layers"). dds/convert.h turns them into messages
// (idl/hullpipe.idl) and validates what arrives. Units: conventions.h.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

namespace hullpipe {

/// Which frame of which camera a map or colour image is, and when: the stamp
/// every ObjectPixelMap and CameraImage carries (paper §3.1; docs/latency.md).
struct FrameStamp {
  uint32_t camera_id = 0;
  uint64_t seq = 0;             ///< The camera's frame_seq (orders its frames).
  int64_t capture_time_ns = 0;  ///< Capture time on the shared clock (CLOCK_REALTIME ns).
  double source_time_s = 0;     ///< The frame's time in its source's own timeline, seconds.
};

/// A virtual triangle mesh or point set to draw (world metres): the cloth, the
/// payload parts, the particles.
struct VirtualMeshDraw {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> triangles;  ///< Empty: draw the vertices as points.
  /// Per triangle (or per point when there are no triangles): drawn red when 1.
  /// Empty: none colliding.
  std::vector<uint8_t> colliding;
  cv::Vec3b colour{200, 200, 200};  ///< BGR when not colliding.
  double point_radius = 0.005;      ///< Radius of drawn points, metres.
};

/// One rendered tile of the novel view (HullView).
struct HullTile {
  cv::Rect rect;   ///< In view pixels.
  cv::Mat depth;   ///< CV_32FC1 eye z metres, kNoDepth where no hull.
  cv::Mat colour;  ///< CV_8UC3 BGR.
  uint32_t node_id = 0, tile_index = 0, tile_count = 1;
  uint64_t pose_seq = 0, frame_seq = 0;
  int64_t capture_time_ns = 0;
  double render_ms = 0;
  uint64_t run_id = 0;  ///< The ViewPose's run (docs/reliability.md, "run id").
};

/// What a VirtualMesh is (values as the IDL's MESH_KIND_*).
enum MeshKind : uint8_t { kMeshCloth = 1, kMeshParticles = 2, kMeshPart = 3 };

/// One virtual mesh (cloth, particles, payload part) as sent by sim_node.
struct VirtualMeshSample {
  uint32_t object_id = 0;
  uint8_t kind = kMeshPart;
  uint64_t frame_seq = 0;
  int64_t capture_time_ns = 0;
  VirtualMeshDraw draw;    ///< Vertices (world metres), triangles, colliding flags, colour.
  double clearance = -1;   ///< Least distance from the hull, metres (< 0: not measured).
  /// The scene element that publishes it: its scene-file section ("cloth",
  /// "payload"; scene_element.h Key()); render_node's stats.json keys what it
  /// drew by it. [a-z0-9_], 1 to kMaxElementKeyChars characters; "unnamed"
  /// for a mesh recorded before meshes named their element.
  std::string element = "mesh";
};

/// The longest VirtualMesh element key.
constexpr size_t kMaxElementKeyChars = 32;

/// One part of a CAD model in the scene (ModelPart), sent once: its geometry in
/// its body frame and what the file calls it (paper §5: the engine's parts).
struct ModelPartSample {
  uint32_t object_id = 0;   ///< model_id + part_index.
  uint32_t model_id = 0;    ///< The model's first part's object id.
  uint32_t part_index = 0, part_count = 1;
  std::string name;         ///< The file's node name.
  std::string file;         ///< The scene's model file.
  std::vector<Eigen::Vector3f> vertices;   ///< Body frame metres.
  std::vector<Eigen::Vector3i> triangles;  ///< CCW seen from outside.
  cv::Vec3b colour{180, 180, 180};         ///< BGR: the material's base colour.
};

/// How near the hull a part is (PART_CONTACT_*).
enum PartContact : uint8_t { kPartClear = 0, kPartNear = 1, kPartColliding = 2 };

/// One part's state after a step (ModelState.parts).
struct PartStateSample {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();        ///< world_from_body translation, metres.
  Eigen::Vector4d orientation{1, 0, 0, 0};                   ///< world_from_body rotation, quaternion w x y z.
  uint8_t contact = kPartClear;                              ///< PartContact.
  double clearance = -1;  ///< Least distance from the hull, metres (< 0: not measured).
};

/// One model's parts after a step against a frameset (ModelState), with what
/// the step cost (§4.1 through the hierarchy).
struct ModelStateSample {
  uint32_t model_id = 0;
  uint64_t frame_seq = 0;
  int64_t capture_time_ns = 0;
  uint64_t triangles = 0;          ///< In the model.
  uint64_t boxes_tested = 0;       ///< Hierarchy boxes tested against the hull.
  uint64_t triangles_queried = 0;  ///< Triangles volume-queried.
  double query_ms = 0;             ///< Collision and clearance time, milliseconds.
  std::vector<PartStateSample> parts;  ///< In part_index order.
};

/// One virtual sphere's state after the step against a frameset
/// (VirtualObjectState), world metres and m/s.
struct VirtualObjectSample {
  /// What the body is (VirtualObjectState SHAPE_*): drawn from the state alone.
  enum class Shape : uint8_t { kSphere = 0, kBox = 1 };
  uint32_t object_id = 0;
  uint64_t frame_seq = 0;
  int64_t capture_time_ns = 0;
  double sim_time = 0;
  Shape shape = Shape::kSphere;
  double radius = 0;                                         ///< kSphere, metres.
  Eigen::Vector3d half_extents = Eigen::Vector3d::Zero();    ///< kBox: along the body's axes, metres.
  Eigen::Vector3d position = Eigen::Vector3d::Zero();        ///< Centre, world metres.
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< world_from_body, unit.
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  bool colliding = false;
};

/// One object's collision with the hull in one step (CollisionReport, paper
/// §4.1–4.2): the colliding triangles and collision points, and the response.
struct CollisionReportSample {
  uint32_t object_id = 0;
  uint64_t frame_seq = 0;
  int64_t capture_time_ns = 0;
  std::vector<uint32_t> triangle_ids;
  std::vector<Eigen::Vector3d> collision_points;  ///< World metres.
  bool has_response = false;
  Eigen::Vector3d cp_obj = Eigen::Vector3d::Zero(), cp_hull = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_rec = Eigen::Vector3d::Zero(), n_hull = Eigen::Vector3d::Zero();
  double d_rec = 0;
  /// The hull surface's motion at CP_hull (collision/hull_motion.h): a
  /// HullVelocityStatus value (0: not estimated), the normal speed (m/s along
  /// n_hull, positive outward) and the seconds it was measured over.
  uint8_t hull_velocity_status = 0;
  double hull_normal_speed = 0;
  double hull_velocity_interval = 0;
};

}  // namespace hullpipe
