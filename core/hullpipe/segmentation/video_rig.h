// The rig of files or live cameras, segmented (paper §3.1): each camera's frames
// come from a reader (capture/camera_reader.h: videos, image sequences, V4L2,
// streams) and become object-pixel maps against the camera's background model
// (segmentation.h), or are read from ready-made masks. Reading is the readers';
// what is here is what every kind of camera shares: the background learnt from
// a video or a live camera's first frames, masks, frame checks, the ends.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "hullpipe/capture/rig_source.h"
#include "hullpipe/segmentation/segmentation.h"

namespace hullpipe {

/// Options of the file/live source.
struct VideoRigOptions {
  std::vector<int> camera_ids;   ///< Subset of camera ids (empty = all).
  SegmentationOptions segmentation;
  int background_frames = 60;    ///< Frames of the background video (or of a live camera without one) to learn from.
  /// Live cameras: the background model follows slow lighting change outside
  /// object pixels at this rate per frame (BackgroundModel::Follow), [0, 1]; 0: fixed.
  double background_rate = 0.05;
  /// Video and image files too: follow the background at background_rate (the
  /// adaptive model). Off by default: a recorded rig's background was taken
  /// just before its video, and the held-out table in docs/benchmarks.md
  /// ("Segmentation settings") measures what following costs or buys there.
  bool follow_files = false;
  /// Live cameras: the input ends when no camera delivered a frame for this long, seconds.
  /// Before the first frame the wait is at least kFirstLiveFrameS: a stream
  /// that starts late (an encoder starting up on a loaded machine) is waited for.
  double live_timeout_s = 5;
  static constexpr double kFirstLiveFrameS = 15;
  /// Polled while learning a live background (which waits for frames): true aborts.
  std::function<bool()> stop_requested;
};

/// Opens a rig (LoadRig: Utrecht directory or YAML rig file). Each camera's
/// `frames` may be a video file, a printf pattern of images, or "v4l2:<index>" for
/// a live camera. The background model is learnt from `background` (video, image,
/// or "v4l2:<index>": the first frames seen). Cameras with ready-made `masks` use
/// them instead of segmenting. Throws CalibrationError / std::runtime_error with a
/// clear message when the rig or a camera cannot be opened.
std::unique_ptr<RigSource> OpenVideoRig(const std::string& rig_path, const VideoRigOptions& options);

}  // namespace hullpipe
