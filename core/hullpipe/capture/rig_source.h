// A multi-camera source of frames for capture_node (paper §3.1's input): each
// Next() gives one frame of every selected camera with its object-pixel map.
// How the maps are made is the implementation's business: a rig of videos, image
// sequences or live cameras segmented against their backgrounds
// (segmentation/video_rig.h), or the synthetic scene with exact maps
// (evaluation/synthetic_source.h). Reading a camera's frames alone is
// camera_reader.h.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/geometry/aabb.h"
#include "hullpipe/geometry/camera.h"
#include "hullpipe/geometry/rigid3.h"

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
  /// Frames in the input from the first, as the files declare them (the
  /// fewest of any camera: a frameset needs every camera); 0 where unknown
  /// (live cameras, image sequences, containers that do not say).
  virtual int64_t frame_count() const { return 0; }
  /// True if frames come as the cameras deliver them (V4L2, network streams):
  /// not paced, not skippable, stamped on arrival.
  virtual bool live() const { return false; }
  /// After Next or Skip returned false: empty when the input simply ended (every
  /// camera at its last frame); otherwise one line saying why it ended early: a
  /// camera ended while others went on (a frameset needs every camera, so the
  /// input ends at the first camera to end), or a video ended well before the
  /// frame count its container declares (truncated or damaged). Cleared by Rewind.
  virtual std::string IncompleteEnd() const { return {}; }
  /// Per selected camera: true if its pose comes live from a tracker (the rig
  /// entry's `tracked: topic`, geometry/calibration.h): the source leaves its
  /// RigFrame::poses empty and capture_node poses its frames by the tracker's
  /// samples (capture/live_pose_track.h). Empty: none.
  virtual std::vector<bool> tracked_by_topic() const { return {}; }
};

/// True if `ids` is empty (every camera) or holds `id`: a source's camera subset.
bool CameraSelected(const std::vector<int>& ids, int id);

}  // namespace hullpipe
