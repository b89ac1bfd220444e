// Snapshot mode (docs/recording.md): the recorder keeps the last N seconds (or bytes)
// of traffic in memory and writes them to a new recording when told (a command
// on the domain or SIGUSR1) — for when something interesting just happened.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <vector>

#include "hullpipe/record/recording.h"

namespace hullpipe::record {

/// Settings of SnapshotBuffer.
struct SnapshotOptions {
  double seconds = 10;   ///< The window: samples that arrived at most this long before the trigger.
  /// Memory bound: the oldest samples go first once the window holds more
  /// (the durable samples below count too). Never unbounded.
  int64_t max_bytes = int64_t(1) << 30;
  /// Bounds: seconds in (0, 3600]; max_bytes in [4096, 64 GiB]. Throws
  /// std::invalid_argument naming the flag (--snapshot-seconds, --snapshot-bytes).
  void Check() const;
};

/// A transient-local topic's samples older than the window are kept up to this
/// many instances (keys: one per camera) times the topic's depth: the recorder
/// does not read keys, and calibration is one sample per camera.
constexpr int64_t kDurableInstances = 64;

/// The last `seconds` of samples, by arrival time. Samples of transient-local
/// topics (calibration) that fall out of the window are kept as a replay needs
/// them (the last kDurableInstances x depth of each such topic), so a snapshot
/// replays on its own. Not thread-safe.
class SnapshotBuffer {
 public:
  /// Throws std::invalid_argument if options fail Check().
  explicit SnapshotBuffer(const SnapshotOptions& options);
  /// Declares a topic (before its samples); its id is the sample's topic_id.
  void AddTopic(const TopicInfo& topic);
  /// Adds a sample (arrival order), then drops what is older than the window
  /// before this sample's arrival and what exceeds max_bytes. Samples of a topic
  /// not added are refused (std::invalid_argument).
  void Add(Sample sample);
  /// Drops what arrived more than `seconds` before `now_ns` (the trigger's time).
  void TrimTo(int64_t now_ns);
  /// The durable samples kept from before the window, then the window, in
  /// arrival order.
  std::vector<Sample> Contents() const;
  const std::vector<TopicInfo>& topics() const { return topics_; }
  int64_t bytes() const { return bytes_; }
  size_t size() const;
  /// Samples dropped for the byte bound (not for age), so far.
  int64_t dropped_for_bytes() const { return dropped_for_bytes_; }

 private:
  void Expire(int64_t now_ns);
  SnapshotOptions options_;
  std::vector<TopicInfo> topics_;
  std::map<int64_t, size_t> topic_index_;
  std::deque<Sample> window_;
  std::map<int64_t, std::deque<Sample>> durable_;  ///< by topic id
  int64_t bytes_ = 0, dropped_for_bytes_ = 0;
};

}  // namespace hullpipe::record
