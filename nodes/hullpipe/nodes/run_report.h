// render_node's end-of-run report: stats.json (docs/reliability.md,
// "stats.json"; docs/latency.md for its latency budget) and the table printed
// at the end. It keeps what the run tallies -- every node's newest NodeStats,
// the collision responses by hull velocity (docs/collision.md, "Hull
// velocity"), what was drawn, the CAD models' query costs and their parts'
// contacts (docs/models.md), the payload parts' clearances -- and writes them
// with what the controller knows of its own run (RunFacts). DDS-free, GL-free.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hullpipe/nodes/latency_budget.h"
#include "hullpipe/pipeline/messages.h"
#include "hullpipe/pipeline/node_stats.h"

namespace hullpipe::nodes {

/// What render_node's controller knows of the run when the report is written.
struct RunFacts {
  int width = 0, height = 0, tiles = 0;  ///< The view, pixels; its tiles.
  uint64_t run_id = 0;
  std::map<std::string, uint64_t> ignored_from_other_runs;  ///< Samples by kind (RunFilter::ignored).
  uint64_t calibrations_refused = 0;                        ///< CameraInfo changing a calibration mid-run.
  /// Once every capture node ended: the cameras whose input ended early.
  std::optional<std::vector<int>> cameras_ended_early;
  uint64_t frames_composited = 0, last_frame_seq = 0;
  std::map<std::string, int> recon_outages;  ///< Times each recon node fell silent.
  nlohmann::json world;                           ///< The world drawn (docs/rigs.md).
  NodeStatsSample render;                         ///< render's own report, now.
  uint64_t reference_frames = 0, framesets_complete = 0;  ///< render's assembler's.
};

class RunReport {
 public:
  /// Most node names whose reports are kept.
  static constexpr size_t kMaxNodes = 256;
  /// Keeps `m` as its node's newest report. A name past kMaxNodes is ignored,
  /// counted (node_stats_over_limit) and said once: returns false.
  bool OnNodeStats(const NodeStatsSample& m);
  const std::map<std::string, NodeStatsSample>& node_stats() const { return node_stats_; }
  uint64_t node_stats_over_limit() const { return node_stats_over_limit_; }

  /// A CollisionReport: whether it has collision points, and its response's hull
  /// velocity (a HullVelocityStatus value, 0: none, unknown values ignored; the
  /// normal speed, m/s, counted where measured or clamped and finite).
  void OnCollisionReport(bool has_points, uint8_t hull_velocity_status, double hull_normal_speed);

  /// One composited frame: states (spheres, boxes) drawn colliding, meshes drawn, whether lit,
  /// and the fraction of its pixels that are hull.
  void OnFrameDrawn(uint64_t spheres_colliding, uint64_t meshes, bool lit, double hull_fraction);

  /// A model's state for a frameset not seen before (its query's cost).
  void OnModelFrameset(const ModelStateSample& state);
  /// A CAD model part's geometry arrived (name, file, triangles kept).
  void OnModelPart(const ModelPartSample& part);
  /// A CAD model part drawn in one frame: its contact (PartContact) and its
  /// clearance, metres (negative: not measured).
  void OnModelPartDrawn(uint32_t object_id, uint8_t contact, double clearance);
  /// Most (element, object) pairs whose meshes are reported; later ones are
  /// counted (meshes_over_limit).
  static constexpr size_t kMaxMeshObjects = 4096;
  /// A scene element's mesh drawn in one frame (VirtualMesh): the element's key
  /// ("payload", "cloth"), the object, its clearance, metres (negative: not
  /// measured), and whether any of it collides. stats.json's "elements" keys
  /// them by element, then object id.
  void OnMeshDrawn(const std::string& element, uint32_t object_id, double clearance, bool colliding);

  /// The latency budget from every node's newest report and `render`
  /// (nodes/latency_budget.h).
  LatencyBudget Budget(const NodeStatsSample& render) const;
  /// stats.json.
  nlohmann::json StatsJson(const RunFacts& facts) const;
  /// The end-of-run table: one row per node, backends, runs ignored, models,
  /// the latency budget, render's frameset assembly.
  std::string Table(const RunFacts& facts) const;
  /// stats.json's "models": per model, its query's cost and each part's
  /// contacts and clearances.
  nlohmann::json ModelsJson() const;

 private:
  struct ModelStats {
    uint64_t framesets = 0, boxes_tested = 0, triangles_queried = 0, triangles = 0;
    std::vector<float> query_ms;  // at most kMaxSamples
  };
  struct PartStats {
    uint32_t model_id = 0;
    std::string name, file;
    size_t triangles = 0;
    uint64_t frames_colliding = 0, frames_near = 0;
    std::vector<float> clearance_m;  // per frame drawn, while measured (at most kMaxSamples)
  };
  static constexpr size_t kMaxSamples = 100000;

  std::map<std::string, NodeStatsSample> node_stats_;  // at most kMaxNodes names
  uint64_t node_stats_over_limit_ = 0;
  uint64_t collision_reports_ = 0;
  std::map<uint8_t, uint64_t> hull_velocity_statuses_;  // responses by hull velocity status
  double hull_speed_max_ = 0, hull_speed_sum_ = 0;     // of |normal speed| measured or clamped, m/s
  uint64_t collisions_drawn_ = 0, meshes_drawn_ = 0, lit_frames_ = 0;
  double hull_fraction_sum_ = 0;
  std::map<uint32_t, ModelStats> model_stats_;  // model id -> what its steps cost
  std::map<uint32_t, PartStats> parts_;         // object id -> a model part's contacts
  struct MeshStats {
    uint64_t frames_drawn = 0, frames_colliding = 0;
    double min_clearance_m = -1;  // < 0: never measured
  };
  std::map<std::pair<std::string, uint32_t>, MeshStats> mesh_stats_;  // (element, object); at most kMaxMeshObjects
  uint64_t meshes_over_limit_ = 0;
};

}  // namespace hullpipe::nodes
