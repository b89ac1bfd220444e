// capture_node's run-time logic (paper §3.1): publishes every selected camera's
// calibration once, then per frame, paced at the source's rate (or unpaced), one
// object-pixel map and one colour image per camera under one frame sequence
// number, with the frame's capture time (when it was due and read). Bad frames
// are skipped and counted; the end of input ends the run (or rewinds with
// loop). DDS-free; tests drive it with a FakeClock and a synthetic source.
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

#include "hullpipe/geometry/aabb.h"
#include "hullpipe/geometry/camera.h"
#include "hullpipe/nodes/clock.h"
#include "hullpipe/nodes/node_counters.h"
#include "hullpipe/segmentation/rig_source.h"

namespace hullpipe::nodes {

/// capture_node's settings (its flags).
struct CaptureOptions {
  int64_t frames = 0;       ///< Stop after this many frames (0: end of input).
  double fps = 0;           ///< Pace at this rate (0: the source's rate), (0, 1000].
  bool fast = false;        ///< Do not pace.
  bool loop = false;        ///< Rewind at the end of input.
  double image_scale = 0.5;  ///< Scale of the published colour images, [0.05, 1].
  /// Throws std::invalid_argument naming the flag out of range.
  void Check() const;
};

/// Where capture's outputs go (CameraInfo, ObjectPixelMap, CameraImage).
class CaptureSink {
 public:
  virtual ~CaptureSink() = default;
  virtual void PublishCameraInfo(const Camera& camera, const Aabb& workspace) = 0;
  /// One camera's map (CV_8UC1) and image (CV_8UC3, already scaled) of frame `seq`.
  virtual void PublishFrame(uint32_t camera_id, uint64_t seq, int64_t capture_time_ns, double source_time_s,
                            uint32_t camera_count, const cv::Mat& map, const cv::Mat& image) = 0;
};

class CaptureController {
 public:
  CaptureController(CaptureOptions options, const Clock& clock, RigSource& source, CaptureSink& sink);
  /// Publishes every camera's calibration (call once, before the first Step).
  void PublishCalibration();
  /// Starts the pacing clock now (call after waiting for readers).
  void Start();
  /// Waits for the next frame's due time, reads, segments and publishes it.
  /// Returns false when the run is over (frames reached or end of input).
  bool Step();
  int64_t published() const { return published_; }
  double rate() const { return rate_; }
  NodeCounters& counters() { return counters_; }
  const NodeCounters& counters() const { return counters_; }

 private:
  CaptureOptions o_;
  const Clock& clock_;
  RigSource& source_;
  CaptureSink& sink_;
  NodeCounters counters_;
  double rate_ = 0;
  double start_s_ = 0;
  uint64_t seq_ = 0;
  int64_t published_ = 0;
  RigFrame frame_;
};

}  // namespace hullpipe::nodes
