// capture_node's run-time logic (paper §3.1): publishes every selected camera's
// calibration once, then per frame one object-pixel map and one colour image per
// camera. Bad frames are skipped and counted; the end of input ends the run (or
// rewinds with loop). DDS-free; tests drive it with a FakeClock.
//
// File and synthetic sources are paced on a capture timeline shared by every
// capture node of the run: frame index i is due at start_ns + i / fps (wall
// clock), is numbered i + 1 and stamped with that due time, so maps of one
// instant carry equal capture times whichever process sent them. The first
// capture node announces the timeline (or the launcher gives it); a node that
// starts later joins at the frame due now, and every node adopts the earliest
// start it hears of. Live sources are not paced: each frame is stamped on
// arrival minus the camera's latency and numbered by its place on the timeline.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/geometry/aabb.h"
#include "hullpipe/geometry/camera.h"
#include "hullpipe/pipeline/clock.h"
#include "hullpipe/pipeline/messages.h"
#include "hullpipe/pipeline/node_counters.h"
#include "hullpipe/capture/live_pose_track.h"
#include "hullpipe/capture/rig_source.h"

namespace hullpipe::nodes {

/// capture_node's settings (its flags).
struct CaptureOptions {
  int64_t frames = 0;       ///< Stop after this many frames (0: end of input).
  double fps = 0;           ///< Pace at this rate (0: the source's rate), (0, 1000].
  bool fast = false;        ///< Do not pace.
  bool loop = false;        ///< Rewind at the end of input.
  double image_scale = 0.5;  ///< Scale of the published colour images, [0.05, 1].
  /// Send each colour image only around its camera's object pixels
  /// (ImageRectAroundObjectPixels of the map's object rectangle: all that
  /// texturing reads), as CameraImage's region (--image-region).
  bool image_regions = false;
  /// The timeline's start (CLOCK_REALTIME ns; --start-time); 0: adopt an announced
  /// one or announce one at Start().
  int64_t start_ns = 0;
  /// A paced node more than this many seconds (and two frames) behind the
  /// timeline skips ahead to the frame due now (counted as dropped), (0, 60].
  double max_lag_s = 0.1;
  /// An announced timeline starting further than this from now (either way) is
  /// refused, named once and counted: a peer's clock or a hostile sample (a
  /// start of 1 ns skipped the whole input, and with --loop 4.5e10 frames),
  /// not a run of this lab, whose nodes start within minutes of each other;
  /// [1, 86400] s (--timeline-window).
  double timeline_window_s = 600;
  /// Threads that scale, encode and write the cameras' frames at once when the
  /// sink allows it (CaptureSink::Concurrent); 0: the machine's cores (--threads).
  int threads = 0;
  /// A camera posed live (RigSource::tracked_by_topic): how far a frame may be
  /// from the tracker's nearest sample and still take it (LivePoseTrack's
  /// max_hold_s), (0, 1] s (--camera-pose-hold). A frame further from every
  /// sample is not published for that camera (counted): a wrong pose would
  /// carve the hull wrongly.
  double camera_pose_hold_s = 0.05;
  /// Throws std::invalid_argument naming the flag out of range.
  void Check() const;
};

/// Raw images (BGR8) of one frame of all cameras above this many bytes go out as
/// JPEG by default: 20 cameras of 1024x768 at half size are 11.8 MB a frame,
/// sent to each recon node (~600 MB/s at 25 fps to two of them), where their
/// transport took 95-137 ms p95 (docs/benchmarks.md, "Many cameras on a GPU
/// machine"); the 4-camera Utrecht rig's 0.94 MB stay raw.
constexpr double kAutoJpegAboveBytes = 2.0 * 1024 * 1024;
/// The quality of those JPEGs (texture colours within a few levels).
constexpr int kAutoJpegQuality = 90;

/// capture_node --jpeg: the JPEG quality its images go out with (0: raw BGR8).
/// `requested` in [0, 100] is kept; -1 (auto) gives kAutoJpegQuality when the
/// cameras' images at `image_scale` (each side rounded as cv::resize does)
/// would pass kAutoJpegAboveBytes raw, else 0.
int ImageJpegQuality(int requested, const std::vector<Camera>& cameras, double image_scale);

/// capture_node --image-region: "object" sends each image only around its
/// object pixels (CaptureOptions::image_regions), "whole" the whole image,
/// "auto" (the default) the former when the cameras' images at `image_scale`
/// would pass kAutoJpegAboveBytes raw a frame, as --jpeg -1 decides. A
/// viewer then shows black around the object (docs/gpu.md). Throws
/// std::invalid_argument naming --image-region for another word.
bool ImageRegions(const std::string& requested, const std::vector<Camera>& cameras, double image_scale);

/// Wall milliseconds a sink spent on one camera's frame: encoding the map and
/// image into messages, and writing them (the budget's "encode" and "publish").
struct PublishTimes {
  double encode_ms = 0, write_ms = 0;
};

/// A region of a camera's scaled colour image (CaptureOptions::image_regions).
struct ImageRegion {
  cv::Rect rect;     ///< In the whole scaled image's pixels.
  cv::Size whole;    ///< The whole scaled image's size.
};

/// The pixels of `region` (clipped to the scaled image) of `image` scaled by
/// `scale` in (0, 1] with cv::INTER_AREA, exactly as cv::resize's whole image
/// cropped to it; only the region's source pixels are resized where 1 / scale
/// is a whole number dividing the image's size (the default half size), else
/// the whole image. An empty region gives an empty image. The scaled image's
/// size is ScaledImageSize(image.size(), scale).
cv::Mat ScaledImageRegion(const cv::Mat& image, double scale, const cv::Rect& region);
/// The size cv::resize gives `size` scaled by `scale` (each side rounded to
/// the nearest, half to even).
cv::Size ScaledImageSize(cv::Size size, double scale);

/// One camera's share of a frame, as capture hands it to its sink.
struct CameraFrameOut {
  FrameStamp stamp;           ///< The camera, its sequence number, capture and source time.
  uint32_t camera_count = 0;  ///< Cameras in the rig's frameset.
  cv::Mat map;                ///< Object-pixel map, CV_8UC1 (non-zero: object).
  /// Colour image, CV_8UC3, already scaled (--image-scale): the whole image,
  /// or with image_region only that region's pixels.
  cv::Mat image;
  /// With image_regions: where `image` lies in the whole scaled image (around
  /// the map's object pixels; an empty rect and an empty `image` for none).
  std::optional<ImageRegion> image_region;
  const Rigid3d* cam_from_world = nullptr;  ///< A tracked camera's pose this frame; nullptr: fixed.
};

/// Where capture's outputs go (CameraInfo, ObjectPixelMap, CameraImage).
class CaptureSink {
 public:
  virtual ~CaptureSink() = default;
  virtual void PublishCameraInfo(const Camera& camera, const Aabb& workspace) = 0;
  /// One camera's map and image of a frame. Returns the time it took (zeros:
  /// not timed).
  virtual PublishTimes PublishFrame(const CameraFrameOut& frame) = 0;
  /// The timeline this node starts (CaptureTimeline, transient-local).
  virtual void AnnounceTimeline(int64_t start_ns, double fps) = 0;
  /// True if PublishFrame may be called for different cameras at once (the
  /// DDS writers'; a frame's cameras are then encoded on several cores).
  virtual bool Concurrent() const { return false; }
};

class CaptureController {
 public:
  CaptureController(CaptureOptions options, const Clock& clock, RigSource& source, CaptureSink& sink);
  /// Publishes every camera's calibration (call once, before the first Step).
  void PublishCalibration();
  /// A timeline announced by another capture node (or this node's own, echoed):
  /// adopted if it starts earlier than the one in use, has this node's rate and
  /// starts within timeline_window_s of now; one outside the window is refused
  /// (warned once, counted in timelines_refused()).
  void OnTimeline(int64_t start_ns, double fps);
  /// A tracker's sample of camera `camera_id`'s pose (CameraPose): kept for a
  /// camera of this node posed live (RigSource::tracked_by_topic), ignored for
  /// any other (another node's camera). A sample LivePoseTrack refuses (out of
  /// order, not a pose) is named once and counted rejected.
  void OnCameraPose(uint32_t camera_id, int64_t stamp_ns, const Rigid3d& world_from_camera);
  /// Called in Step just before a frame's live-posed cameras are posed, so the
  /// samples that came while it waited for the frame are in (capture_node takes
  /// its CameraPose reader there).
  void SetPoseRefresh(std::function<void()> refresh) { pose_refresh_ = std::move(refresh); }
  /// True if any of this node's cameras is posed live (its CameraPose samples wanted).
  bool posed_live() const { return !live_poses_.empty(); }
  /// Frames of live-posed cameras not published for want of a pose near them.
  int64_t unposed_frames() const { return unposed_frames_; }
  /// Announced timelines refused for their start (outside the window).
  int64_t timelines_refused() const { return timelines_refused_; }
  /// Starts: on the --start-time timeline, else on one heard of (OnTimeline before
  /// Start), else on a new one starting now, announced. Call after waiting for readers.
  void Start();
  int64_t timeline_start_ns() const { return start_ns_; }
  /// Waits for the next frame's due time (at most kMaxWaitS, then returns true
  /// having published nothing), reads, segments and publishes it. Live sources:
  /// publishes what the cameras delivered (maybe nothing yet). Returns false when
  /// the run is over (frames reached or end of input).
  bool Step();
  int64_t published() const { return published_; }
  /// Non-empty when the input ended early at least once (RigSource::IncompleteEnd):
  /// the frames before it were published, the node should exit non-zero.
  const std::string& incomplete() const { return incomplete_; }
  static constexpr double kMaxWaitS = 0.2;
  double rate() const { return rate_; }
  NodeCounters& counters() { return counters_; }
  const NodeCounters& counters() const { return counters_; }

 private:
  CaptureOptions o_;
  const Clock& clock_;
  RigSource& source_;
  CaptureSink& sink_;
  NodeCounters counters_;
  /// Wall time of frame index `index` on the timeline.
  int64_t DueNs(int64_t index) const { return start_ns_ + int64_t(std::llround(double(index) * 1e9 / rate_)); }
  /// Skips the source ahead to the frame due now when it is behind by more than
  /// `lag_s` (or at all, when joining). Returns false at the end of input.
  bool CatchUp(double lag_s, const char* why);
  double rate_ = 0;
  double frame_s_ = 0;        // a frame's read-to-published time, smoothed
  bool behind_said_ = false;  // the falling-behind line said (once)
  int64_t start_ns_ = 0;
  bool started_ = false;
  bool rejoin_ = false;  ///< An earlier timeline was adopted: skip to its frame due now.
  bool catching_up_ = false;  ///< CatchUp ran out of its time slice before the frame due now.
  int64_t timelines_refused_ = 0;
  int64_t index_ = 0;             ///< Timeline index of the next frame read.
  std::vector<uint64_t> last_seq_;  ///< Per camera, the last frame_seq sent.
  int64_t published_ = 0;
  std::string incomplete_;
  RigFrame frame_;
  std::map<uint32_t, LivePoseTrack> live_poses_;  // by camera id: the cameras posed live
  std::function<void()> pose_refresh_;
  std::set<std::string> pose_said_;  // kinds of pose refusal named once
  int64_t unposed_frames_ = 0;
  /// At the source's end: logs and keeps an incomplete end. Returns true to go on
  /// (--loop rewound the source).
  bool AtEnd();
  /// Threads for the cameras' publication (CaptureOptions::threads).
  int PublishThreads() const;
};

}  // namespace hullpipe::nodes
