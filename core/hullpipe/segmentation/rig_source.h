// Sources of frames for capture_node: a rig of videos or image sequences (with
// background segmentation), live V4L2 cameras, or the built-in synthetic scene with
// exact masks. Each Next() gives one frame of every selected camera.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/geometry/aabb.h"
#include "hullpipe/geometry/camera.h"
#include "hullpipe/segmentation/segmentation.h"

namespace hullpipe {

/// One frame of all selected cameras. A camera whose frame could not be read this
/// time has an empty image and map, and a line in `errors`.
struct RigFrame {
  std::vector<cv::Mat> images;  ///< CV_8UC3 BGR, calibrated size.
  std::vector<cv::Mat> maps;    ///< CV_8UC1 object-pixel maps.
  std::vector<std::string> errors;
  double time_s = 0;            ///< Source time of the frame (frame index / fps).
  /// Live sources: per camera, when its frame was captured (CLOCK_REALTIME ns:
  /// arrival minus the camera's latency setting); 0 for file and synthetic
  /// sources, whose frames take their due time on the capture timeline.
  std::vector<int64_t> capture_ns;
  /// Per camera: a tracked camera's cam_from_world at this frame (empty optional:
  /// a fixed camera, whose pose is its calibration's).
  std::vector<std::optional<Rigid3d>> poses;
  /// Per camera: wall milliseconds spent reading (decoding) its frame and
  /// segmenting it into the map (the latency budget's capture stages,
  /// docs/latency.md); empty when the source does not time them. Cameras are
  /// read in parallel: the frame's stage time is the slowest camera's.
  std::vector<double> read_ms, segment_ms;
};

/// A multi-camera source.
class RigSource {
 public:
  virtual ~RigSource() = default;
  virtual const std::vector<Camera>& cameras() const = 0;
  /// Cameras in the whole rig (>= cameras().size() when a subset is selected):
  /// the size of a complete frameset.
  virtual int rig_camera_count() const = 0;
  virtual Aabb workspace() const = 0;
  /// Nominal frame rate of the source (frames per second).
  virtual double fps() const = 0;
  /// Reads the next frame. Returns false at the end of the input (every camera
  /// ended). Never throws on bad input: bad frames are reported in RigFrame::errors.
  virtual bool Next(RigFrame* frame) = 0;
  /// Restarts from the first frame (for --loop). Returns false if not possible.
  virtual bool Rewind() = 0;
  /// Passes over the next frame without segmenting it (joining a shared timeline
  /// late). Returns false at the end of the input.
  virtual bool Skip() {
    RigFrame scratch;
    return Next(&scratch);
  }
  /// True if frames come as the cameras deliver them (V4L2, network streams):
  /// not paced, not skippable, stamped on arrival.
  virtual bool live() const { return false; }
  /// After Next or Skip returned false: empty when the input simply ended (every
  /// camera at its last frame); otherwise one line saying why it ended early: a
  /// camera ended while others went on (a frameset needs every camera, so the
  /// input ends at the first camera to end), or a video ended well before the
  /// frame count its container declares (truncated or damaged). Cleared by Rewind.
  virtual std::string IncompleteEnd() const { return {}; }
};

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
  double live_timeout_s = 5;
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

/// Options of the synthetic source.
struct SyntheticRigOptions {
  /// Bounds (checked by OpenSyntheticRig): a 4096x4096 camera is 16 MB a map and
  /// image; 100000x100000 once grew past 9.8 GB without a word.
  static constexpr int kMaxSide = 4096, kMaxCameras = 64;
  int cameras = 4;                ///< [1, kMaxCameras]
  int width = 320, height = 240;  ///< Pixels, each in [8, kMaxSide].
  double fps = 25;                ///< (0, 1000]
  double hfov = 1.0;             ///< radians
  Distortion distortion{};
  int frames = 250;              ///< Frames before the input ends.
  std::vector<int> camera_ids;   ///< Subset (empty = all).
  std::string scene = "figure";  ///< NamedScene: figure, hand, sphere, box, torus, mixed.
  std::string placement = "ring";  ///< ring (4 m around the scene, 2 m up) or dome (3 m).
  /// A tracked camera (0: none): this camera moves on SyntheticTrackedPose's path and
  /// each frame carries its pose.
  int tracked_camera = 0;
};

/// The path of the synthetic source's tracked camera: its calibrated pose turned
/// about the vertical axis through `target` by 0.35 sin(t) rad, then moved by
/// 0.4 sin(t) m along world x and raised by 0.1 sin(2t) m (world z points down;
/// it no longer looks at the target), t in seconds of source time.
Rigid3d SyntheticTrackedPose(const Camera& calibrated, const Eigen::Vector3d& target, double t);

/// The built-in synthetic scene (NamedScene, moving, seen by RingCameras or
/// DomeCameras): exact maps, shaded colour, no files needed. Throws
/// std::invalid_argument on bad options (naming them).
std::unique_ptr<RigSource> OpenSyntheticRig(const SyntheticRigOptions& options);

}  // namespace hullpipe
