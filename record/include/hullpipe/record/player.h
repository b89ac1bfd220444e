// Playing a recording (docs/recording.md): which samples, when, how often — without any
// transport. `hullpipe_replay` hands each sample to a DDS writer; tests hand them
// to a vector (like rosbag2's player, which takes a reader object).
#pragma once

#include <atomic>
#include <functional>
#include <string>
#include <vector>

#include "hullpipe/record/recording.h"

namespace hullpipe::record {

/// Settings of Play.
struct PlayerOptions {
  /// Speed: 1 the original timing, 2 twice as fast; 0 as fast as the sink takes
  /// the samples (no waiting between them).
  double rate = 1.0;
  bool loop = false;            ///< Start over at the end (until stopped).
  int max_loops = 0;            ///< With loop: stop after this many passes (0: no limit).
  /// Skip the first seconds of the recording. Samples of transient-local topics
  /// (e.g. CameraInfo) before the offset are still played, at once, so late
  /// joiners downstream get them as in the original run.
  double start_offset_s = 0;
  /// Stop at this many seconds after the recording's first sample (0: at its end).
  /// --duration D on the command line is end_offset_s = start_offset_s + D.
  double end_offset_s = 0;
  std::vector<std::string> include, exclude;  ///< Topic name globs (TopicSelected).
  /// Bounds: rate 0 or in [kMinRate, kMaxRate]; start_offset_s and end_offset_s in
  /// [0, kMaxStartOffsetS], end_offset_s 0 or above start_offset_s (and, checked by
  /// Play, the start not past the recording's end).
  static constexpr double kMinRate = 1e-3, kMaxRate = 1e3, kMaxStartOffsetS = 1e6;
  /// Throws std::invalid_argument naming the bad flag.
  void Check() const;
};

/// Keyboard, command-topic (or test) control of a running Play; thread-safe.
struct PlayerControl {
  std::atomic<bool> paused{false};
  std::atomic<int> steps{0};    ///< While paused: samples to release one by one.
  std::atomic<bool> stop{false};
  /// A request to jump to this many seconds after the recording's first sample
  /// (negative: none). Play takes it (resets it to -1) before the next sample,
  /// sends the transient-local samples before that point at once, as a start
  /// offset does, and goes on from there; a seek past the end ends the pass.
  std::atomic<double> seek_s{-1};
  /// A request for a new rate (negative: none; 0 or in [kMinRate, kMaxRate], else
  /// ignored and counted in PlayStats::refused_requests). Timing continues from the
  /// next sample at the new rate.
  std::atomic<double> new_rate{-1};
  /// Set by Play: seconds after the recording's first sample of the last sample
  /// played (for a relative seek: the keyboard's 5-s steps).
  std::atomic<double> position_s{0};
};

/// Where the player's time comes from (monotonic seconds); tests pass a fake.
struct PlayerClock {
  virtual ~PlayerClock() = default;
  virtual double Now() = 0;
  virtual void SleepFor(double seconds) = 0;
};

/// What Play did.
struct PlayStats {
  int64_t samples = 0;       ///< Handed to the sink.
  int loops = 0;             ///< Complete passes.
  int seeks = 0;             ///< Seek requests taken.
  int refused_requests = 0;  ///< Rate requests out of bounds.
  double max_lateness_s = 0; ///< Largest delay of a sample behind its due time.
};

/// The longest single sleep of Play: a stop request is honoured within it, at any rate.
constexpr double kSleepSliceS = 0.05;

/// Plays the recording's selected samples into `sink` in arrival order, each at
/// its original arrival time (relative to the first played sample) divided by
/// rate, from start_offset_s to end_offset_s. Honours `control` (pause, step,
/// stop, seek, rate) between samples and during the wait for one. clock: nullptr
/// uses the steady clock. Throws std::invalid_argument if options fail Check() or
/// the start offset is past the end; RecordingError if the file turns out damaged.
PlayStats Play(const RecordingReader& recording, const PlayerOptions& options,
               const std::function<void(const TopicInfo&, const Sample&)>& sink, PlayerControl* control = nullptr,
               PlayerClock* clock = nullptr);

}  // namespace hullpipe::record
