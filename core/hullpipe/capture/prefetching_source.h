// A RigSource that reads one frame ahead (paper §3.1's input, pipelined): while
// capture_node publishes frame i and waits for frame i+1's due time, frame i+1
// is already being read and segmented on another thread, so a frame's read and
// segmentation leave the capture's critical path (docs/latency.md, "capture").
// The frames, their order, their errors and the end of input are the wrapped
// source's exactly; only when they are read changes. Live sources pass through
// unchanged (their cameras' own threads already read ahead, and a live frame's
// stamp is its arrival).
#pragma once

#include <future>
#include <memory>
#include <string>
#include <vector>

#include "hullpipe/capture/rig_source.h"

namespace hullpipe {

class PrefetchingSource final : public RigSource {
 public:
  /// Wraps `inner`, which it owns. The wrapped source's Next/Skip/Rewind are
  /// called from one thread at a time (the reader thread or the caller's, never
  /// both at once), so it needs no locking of its own; its const queries
  /// (cameras, rig_camera_count, workspace, fps, tracked_by_topic) are read once here.
  explicit PrefetchingSource(std::unique_ptr<RigSource> inner);
  /// Waits for a read in flight (at most one frame's read) and ends.
  ~PrefetchingSource() override;
  PrefetchingSource(const PrefetchingSource&) = delete;
  PrefetchingSource& operator=(const PrefetchingSource&) = delete;

  const std::vector<Camera>& cameras() const override { return cameras_; }
  int rig_camera_count() const override { return rig_camera_count_; }
  Aabb workspace() const override { return workspace_; }
  double fps() const override { return fps_; }
  /// The frame read ahead (waiting for it if its read is in flight), or read
  /// now when none is; then starts reading the next one once the caller has
  /// taken two frames in a row without a Skip between (a caller that skips is
  /// behind: reading ahead would only read frames it skips). As the wrapped
  /// source's Next: false at the end of input, errors in `frame`; an exception
  /// the wrapped Next threw on the reader thread is rethrown here.
  bool Next(RigFrame* frame) override;
  /// Passes over the next frame: the one read ahead if any (its read is
  /// waited for and discarded), else the wrapped source's Skip. Reads nothing
  /// ahead afterwards: a run of skips (joining the timeline, catching up)
  /// costs the wrapped Skip each, not a whole read.
  bool Skip() override;
  /// Discards the frame read ahead and rewinds the wrapped source (reading
  /// ahead again after two frames, as at the start).
  bool Rewind() override;
  /// As the wrapped source's, cached when nothing is in flight (at start and
  /// after Rewind).
  int64_t frame_count() const override { return frame_count_; }
  bool live() const override { return live_; }
  std::vector<bool> tracked_by_topic() const override { return tracked_by_topic_; }
  /// The wrapped source's, once a read in flight has ended.
  std::string IncompleteEnd() const override;
  /// Frames read ahead and handed out by Next, and read ahead and then skipped
  /// (for tests).
  int64_t prefetched() const { return prefetched_; }
  int64_t prefetch_discarded() const { return discarded_; }

 private:
  /// Waits for the read in flight; returns its result and moves its frame to `frame` (nullptr: discard).
  bool Collect(RigFrame* frame);
  void StartAhead();

  std::unique_ptr<RigSource> inner_;
  std::vector<Camera> cameras_;
  int rig_camera_count_ = 0;
  Aabb workspace_;
  double fps_ = 0;
  int64_t frame_count_ = 0;
  bool live_ = false;
  std::vector<bool> tracked_by_topic_;  // read once: a rig's setting
  RigFrame ahead_;                  ///< The frame being read ahead (the reader thread's while in flight).
  mutable std::future<bool> read_;  ///< The read in flight, if valid().
  int64_t prefetched_ = 0, discarded_ = 0;
  int streak_ = 0;  ///< Next calls since the start, the last Skip or the last Rewind.
};

/// `inner` wrapped in a PrefetchingSource unless it is live (returned as it is).
std::unique_ptr<RigSource> ReadAhead(std::unique_ptr<RigSource> inner);

}  // namespace hullpipe
