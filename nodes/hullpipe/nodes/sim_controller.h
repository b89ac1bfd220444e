// sim_node's run-time logic (paper §4–§5): each new frameset's visual hull steps
// the virtual scene (its elements: balls, cloth, particles, payload task;
// scenes/scene_element.h) by the frames' source time, so a run or a replay is
// deterministic given its inputs; it publishes what each element gives (each
// body's state and collision report, §4.1 points and §4.2 response; meshes) and
// logs each part's collisions as they start and end. Scene commands change the
// payload spacing while it runs. It keeps the previous frameset's hull so that
// bodies struck by a moving hull are thrown by it (collision/hull_motion.h).
// DDS-free; tests drive it with a FakeClock.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hullpipe/pipeline/clock.h"
#include "hullpipe/util/reject_log.h"
#include "hullpipe/pipeline/messages.h"
#include "hullpipe/pipeline/node_counters.h"
#include "hullpipe/reconstruction/frameset.h"
#include "hullpipe/reconstruction/volume_query.h"
#include "hullpipe/scenes/virtual_scene.h"

namespace hullpipe::nodes {

/// Where sim's outputs go (VirtualObjectState, CollisionReport, VirtualMesh,
/// ModelPart, ModelState).
class SimSink {
 public:
  virtual ~SimSink() = default;
  virtual void PublishState(const VirtualObjectSample& state) = 0;
  virtual void PublishReport(const CollisionReportSample& report) = 0;
  virtual void PublishMesh(const VirtualMeshSample& mesh) = 0;
  /// A CAD model part's geometry: once per part, before its first state.
  virtual void PublishModelPart(const ModelPartSample& part) = 0;
  virtual void PublishModelState(const ModelStateSample& state) = 0;
};

class SimController {
 public:
  /// `scene` is checked (std::invalid_argument naming the key).
  SimController(SceneConfig scene, const Clock& clock, FramesetAssembler& assembler, SimSink& sink);
  /// SceneCommand SET_SPACING: the payload spacing in metres. A value the task
  /// refuses (non-finite, out of range, no payload) is counted as rejected and
  /// logged; returns whether it was taken.
  bool SetSpacing(double spacing_m, uint64_t command_seq);
  /// A command the node does not know, or a malformed one: counted, its
  /// warning line written as RejectLog bounds it (a peer flooding bad commands
  /// does not flood the log).
  void RejectCommand(uint64_t command_seq, const std::string& why);
  /// The refused commands' warning lines.
  const RejectLog& reject_log() const { return reject_log_; }
  /// Input samples the caller could not decode before they reached the
  /// assembler (counted into this node's rejected, with the assembler's own).
  void SetMalformedInput(uint64_t n) { malformed_input_ = n; }
  /// Steps the scene on every new frameset (newest first wins); returns the
  /// framesets stepped. Throws Interrupted (util/interrupt.h) when the stop flag
  /// is set mid-step: the node is stopping.
  int Step();
  /// The flag a long step polls between substeps (nullptr: never stops).
  void set_stop(StopFlag stop) { stop_ = stop; }
  /// Threads of each frameset's hull box search (VolumeQueryOptions::threads:
  /// its six faces at once), clamped to [1, 256]; default 1. The box, and so
  /// every step, is the same with any number.
  void set_query_threads(int threads) { query_options_.threads = std::clamp(threads, 1, 256); }
  /// Step every complete frameset in order, oldest first, instead of the newest
  /// only: a replay into sim_node then gives the same steps however busy the
  /// machine, as long as sim_node falls no more than the history (4 framesets)
  /// behind (sim_node --every-frameset).
  void set_every_frameset(bool every) { every_frameset_ = every; }

  const VirtualScene& scene() const { return scene_; }
  NodeCounters& counters() { return counters_; }
  const NodeCounters& counters() const { return counters_; }
  uint64_t collisions() const { return collisions_; }  ///< Colliding body-steps.
  uint64_t commands_rejected() const { return commands_rejected_; }
  /// CAD model parts' collision starts and ends so far. Each is logged as it
  /// happens at up to kPartEventLinesPerS lines a second of source time (a
  /// burst of kPartEventBurst); past that one line says how many went unlogged
  /// (a model of 200,000 parts once wrote 200,000 lines, 19 MB, in one frame).
  uint64_t part_events() const { return part_events_; }
  /// Of those, the ones not logged one by one.
  uint64_t part_events_unlogged() const { return part_events_unlogged_; }
  static constexpr double kPartEventLinesPerS = 10, kPartEventBurst = 20;
  /// Responses published so far by their hull velocity's status (index: a
  /// HullVelocityStatus value): how many were measured, clamped, had no
  /// previous frameset, ... (kNone counts those with the motion turned off).
  const std::array<uint64_t, 6>& hull_velocity_counts() const { return hull_velocity_counts_; }

 private:
  void StepOne(const Frameset& fs);
  FramesetAssembler& assembler_;
  SimSink& sink_;
  RejectLog reject_log_;  // the refused commands' warning lines, bounded
  bool every_frameset_ = false;
  VirtualScene scene_;
  NodeCounters counters_;
  uint64_t part_events_ = 0, part_events_unlogged_ = 0, part_events_pending_ = 0;
  double part_event_tokens_ = kPartEventBurst, part_event_time_s_ = 0;
  uint64_t collisions_ = 0, commands_rejected_ = 0, malformed_input_ = 0;
  double last_source_time_ = -1;
  StopFlag stop_ = nullptr;
  VolumeQueryOptions query_options_;
  // The previous stepped frameset's hull and its times (hull_motion.h).
  std::unique_ptr<VolumeQuery> previous_query_;
  TimedHull previous_hull_;
  std::array<uint64_t, 6> hull_velocity_counts_{};
};

}  // namespace hullpipe::nodes
