// Assembling framesets (paper §3.1–3.2: a volume query needs every camera's
// object-pixel map of one instant) from maps and images that arrive one by one,
// from cameras that are not frame-locked and may run on several machines.
//
// A frameset is built around one sample of the reference camera (the lowest
// calibrated camera id) at reference time t_ref, its capture time: every other
// camera contributes its sample nearest to t_ref, and all must lie within the
// skew tolerance (default: half the frame period of the slowest camera). The
// choice is deterministic — a function of the cameras' samples only, never of
// the order they arrived in — so several nodes assembling the same traffic build
// the same framesets: a camera's nearest sample is known once it has a sample at
// or after t_ref. The frameset's id (`seq`) is the reference sample's frame_seq;
// frame_seq orders one camera's frames only. Capture times are on a clock the
// cameras' hosts share (PTP or chrony; see docs/architecture.md).
//
// Latest wins: each camera keeps a bounded history of samples; older ones are
// dropped and counted, never queued without bound. Transport-free, so it is
// tested without DDS and with made-up times.
#pragma once

#include <climits>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/geometry/aabb.h"
#include "hullpipe/geometry/camera.h"
#include "hullpipe/pipeline/node_stats.h"
#include "hullpipe/reconstruction/texture.h"
#include "hullpipe/reconstruction/volume_query.h"
#include "hullpipe/util/latency_stats.h"

namespace hullpipe {

/// All cameras' data for one instant.
struct Frameset {
  uint64_t seq = 0;                 ///< The reference camera's frame_seq.
  int64_t capture_time_ns = 0;      ///< The reference time t_ref (the reference sample's capture time).
  double source_time_s = 0;         ///< The reference frame's time in its source's timeline, seconds.
  std::vector<CameraMap> maps;      ///< In camera-id order.
  std::vector<CameraImage> images;  ///< In camera-id order (empty unless wanted).
  std::vector<int64_t> skew_ns;     ///< Per map: its capture time minus t_ref, ns.
  /// The last arrival among its maps and images (the arrival_ns given to
  /// AddMap/AddImage, the node's wall clock ns; 0: none known). A frameset that
  /// waited for a later sample to decide a nearest frame became complete after it.
  int64_t last_arrival_ns = 0;
};

/// One camera's map as it arrives at an assembling node (an ObjectPixelMap).
struct MapSample {
  int camera_id = 0;
  uint64_t seq = 0;              ///< The camera's frame_seq (orders this camera's frames).
  int64_t capture_time_ns = 0;   ///< Its capture time on the shared clock (CLOCK_REALTIME ns).
  int camera_count = 0;          ///< Cameras in a frameset (the rig's size), [1, 64].
  cv::Mat map;                   ///< CV_8UC1, the camera's calibrated size, non-zero = object.
  /// The map's object pixels' bounding rectangle when already known (decoding
  /// its runs gives it: DecodedMap), so the volume query does not scan the map
  /// again for it; nullopt: found when needed.
  std::optional<cv::Rect> object_rect;
  double source_time_s = 0;      ///< The frame's time in its source's timeline.
  uint64_t source_id = 0;        ///< Who sent it (the DDS writer; 0: unknown): a new one is a restart.
  int64_t arrival_ns = 0;        ///< When it arrived, on this node's wall clock (0: unknown).
  /// A tracked camera's pose at this frame, used for it in the frameset instead
  /// of the calibration's (paper §5: the head-mounted camera).
  std::optional<Rigid3d> cam_from_world;
};

/// One camera's colour image as it arrives at an assembling node (a CameraImage),
/// the twin of MapSample for AddImage.
struct ImageSample {
  int camera_id = 0;
  uint64_t seq = 0;             ///< The camera's frame_seq (the map's it belongs to).
  int64_t capture_time_ns = 0;  ///< Its capture time on the shared clock (CLOCK_REALTIME ns).
  cv::Mat image;                ///< CV_8UC3 (BGR), any size.
  uint64_t source_id = 0;       ///< Who sent it (0: unknown).
  int64_t arrival_ns = 0;       ///< When it arrived, on this node's wall clock (0: unknown).
};

/// Collects maps (and images) into framesets by capture time.
class FramesetAssembler {
 public:
  /// max_pending: samples kept per camera while unused (>= 1; the history holds
  /// max_pending + 2 so that a reference sample's neighbours stay). want_images: a
  /// frameset is complete only when each chosen sample's image has arrived too.
  explicit FramesetAssembler(size_t max_pending = 6, bool want_images = false);

  /// Registers a camera's calibration (from CameraInfo). The first one of a
  /// camera id holds for the run: the same again (a restarted capture node's,
  /// the transient-local resend) changes nothing; a different one (size, K,
  /// distortion or pose) is refused: false, counted in calibrations_refused(),
  /// *why names the camera and what changed. A calibration changed mid-run
  /// moved the hull of every frame it is in (a pose moved 0.3 m carved the
  /// person away; a size change rejected every map): a recalibrated rig is a
  /// new run.
  bool SetCamera(const Camera& camera, std::string* why = nullptr);
  /// The rig's workspace (from CameraInfo): the first holds, as SetCamera's;
  /// a different one is refused (false, counted, *why says so).
  bool SetWorkspace(const Aabb& workspace, std::string* why = nullptr);
  /// The workspace from CameraInfo, else DefaultWorkspace of the cameras known.
  Aabb workspace() const;
  size_t camera_count() const { return cameras_.size(); }
  bool HasCamera(int id) const { return cameras_.count(id) > 0; }

  /// The skew tolerance in seconds (> 0), or 0 (the default) for half the frame
  /// period of the slowest camera, measured from its capture times (kDefaultPeriodS
  /// until two frames of every camera have arrived).
  void SetTolerance(double seconds) { tolerance_s_ = seconds > 0 ? seconds : 0; }
  /// The tolerance in use now, seconds.
  double tolerance_s() const;
  static constexpr double kDefaultPeriodS = 0.04;

  /// Adds one camera's map (MapSample says what each field is). A map of a
  /// camera with no calibration yet is parked in the camera's history and checked
  /// when the calibration arrives; if it leaves the history first it counts as
  /// rejected — and moves to dropped if the camera's CameraInfo comes later (a
  /// start-up race, not bad input). Returns false (and counts a rejection, *why
  /// says why) if the map is not CV_8UC1, its size differs from the calibration,
  /// camera_count is out of [1, 64] or object_rect lies outside the map; false
  /// (counted as dropped) if the sample is older than the camera's newest and not
  /// far enough back to be a restart. A camera whose capture times disagree with
  /// their arrival — stamped in the future by more than the tolerance, or later
  /// than the other cameras' by more than max(tolerance, kClockCheckMinS) — has a
  /// clock off (logged once per episode, counted in clock_offsets).
  bool AddMap(MapSample sample, std::string* why = nullptr);
  /// Whether a map of width x height fits camera_id's calibration (true while the
  /// camera has none yet). Checked before a received map is decoded, so a map
  /// claiming 16384x16384 pixels for a 644x486 camera costs no 268-MB decode;
  /// false counts a rejection as AddMap does, *why says why.
  bool CheckMapSize(int camera_id, int width, int height, std::string* why = nullptr);
  /// Whether a colour image of width x height (the whole image, where only a
  /// region of it is sent) fits camera_id's calibration: at most its size
  /// (images may be scaled down, never up; true while the camera has none
  /// yet). Checked before a received image is decoded or a region's whole
  /// image allocated; false counts a rejection as AddMap does, *why says why.
  bool CheckImageSize(int camera_id, int width, int height, std::string* why = nullptr);
  /// Adds one camera's colour image of frame `seq`; same rules as AddMap. Its
  /// arrival_ns counts toward Frameset::last_arrival_ns (no clock check: images
  /// name no sender). A non-BGR8 image is rejected (false, *why says why).
  bool AddImage(ImageSample sample, std::string* why = nullptr);

  /// Id of the newest complete frameset not yet taken, if any.
  std::optional<uint64_t> NewestComplete() const;
  /// True if frameset seq is complete (and not yet taken).
  bool IsComplete(uint64_t seq) const;
  /// Removes and returns frameset `seq` if complete; every older reference sample
  /// is passed over (counted as dropped: superseded, no partner, or for skew).
  /// nullopt if not complete.
  std::optional<Frameset> Take(uint64_t seq);
  /// Take(NewestComplete()).
  std::optional<Frameset> TakeNewest();
  /// Id of the oldest complete frameset not yet taken, if any.
  std::optional<uint64_t> OldestComplete() const;
  /// Take(OldestComplete()): a consumer that steps every frameset in order
  /// (a deterministic replay) passes over none that is still in the history.
  std::optional<Frameset> TakeOldest();
  /// True if frameset seq can no longer be built (at or before the newest taken).
  bool IsGone(uint64_t seq) const { return seq <= taken_up_to_; }

  /// A sample more than kRestartGap frames older than its camera's newest means its
  /// capture source restarted (frame numbers start over): the camera's history is
  /// forgotten (counted per camera); when it is the reference camera, frameset ids
  /// start over too (counted in restarts(), which consumers follow). A frame that is
  /// merely late is never that far behind (history depth 4).
  static constexpr uint64_t kRestartGap = 64;
  /// A camera whose capture times jump by more than kPausePeriods frame periods
  /// (and at least kPauseMinS) paused; logged and counted at its return.
  static constexpr double kPausePeriods = 3, kPauseMinS = 0.15;
  /// A camera that is running (frames on both sides of t_ref, no pause between)
  /// yet out of tolerance in kOffsetFramesets reference frames in a row has a clock
  /// (or latency setting) off by more than the tolerance: logged once per episode.
  static constexpr int kOffsetFramesets = 5;
  /// The delay compared is each camera's least (arrival - capture time) over its
  /// last 31 frames; processing on the capture hosts and a busy receiver still
  /// make those differ by up to a frame period or two on a loaded machine: delays
  /// that differ by less than this are not called a clock error.
  static constexpr double kClockCheckMinS = 0.1;
  uint64_t restarts() const { return restarts_; }

  uint64_t dropped() const { return dropped_; }
  uint64_t rejected() const { return rejected_; }
  /// CameraInfo samples refused for changing a calibration or the workspace.
  uint64_t calibrations_refused() const { return calibrations_refused_; }
  /// Reference frames whose nearest partner of some camera lay outside the tolerance.
  uint64_t dropped_for_skew() const { return dropped_for_skew_; }
  /// Reference frames decided so far: taken, or passed over (superseded by a newer
  /// frameset taken, or left the history).
  uint64_t reference_frames() const { return reference_frames_; }
  /// Of those, the ones that were complete framesets (taken, or complete when passed
  /// over): how many framesets the cameras' streams made, whatever the consumer's
  /// speed — a consumer that takes only the newest takes fewer.
  uint64_t framesets_complete() const { return framesets_complete_; }
  /// Per camera, in id order.
  std::vector<CameraSkewReport> SkewReports() const;

  /// A calibrated camera whose input ended before the others': its newest
  /// capture time lags the newest of all cameras by lag_s (the whole span for a
  /// camera that sent nothing); it sent `frames` frames.
  struct EarlyEnd {
    int camera_id = 0;
    double lag_s = 0;
    uint64_t frames = 0;
  };
  /// Cameras lagging by more than max(kEarlyEndMinS, kEarlyEndPeriods of their
  /// frame period, kEarlyEndFraction of the run's capture-time span), in id
  /// order: file sources of one rig end within a frame or two of each other, and
  /// live streams that end by themselves within a second (the live test's
  /// stand-in streams: up to 0.53 s apart, their decoders' flush), so a camera
  /// beyond that had a shorter (truncated) input and the framesets after its end
  /// are incomplete. Only meaningful once the input has ended (every capture
  /// node's final report): while running, every camera lags by its latency.
  std::vector<EarlyEnd> EndedEarly() const;
  static constexpr double kEarlyEndMinS = 1.0, kEarlyEndPeriods = 5, kEarlyEndFraction = 0.01;

 private:
  struct Sample {
    uint64_t seq = 0;
    int64_t t_ns = 0;
    double source_time_s = 0;
    cv::Mat map, image;
    std::optional<cv::Rect> object_rect;    ///< MapSample::object_rect.
    std::optional<Rigid3d> cam_from_world;  ///< A tracked camera's pose of this frame.
    int64_t map_arrival_ns = 0, image_arrival_ns = 0;  ///< Node wall clock ns (0: unknown).
    bool partnered = false;  ///< Member of a complete frameset.
  };
  struct Cam {
    std::deque<Sample> samples;  ///< Ascending seq.
    uint64_t source_id = 0;
    uint64_t newest_seq = 0;
    int64_t newest_t_ns = 0;
    int64_t first_t_ns = 0;  ///< Capture time of its first frame (since its last restart).
    bool any = false;
    std::deque<int64_t> steps_ns;  ///< Recent capture-time steps per frame.
    double period_s = 0;           ///< Median of steps_ns, seconds (0: no step yet); kept with it.
    SampleStats skew_ms{20000};
    uint64_t frames = 0, unpartnered = 0, pauses = 0, restarts = 0, clock_offsets = 0;
    int out_of_tolerance_run = 0;
    std::deque<int64_t> delays_ns;  ///< Recent arrival - capture time.
    int64_t delay_least_ns = 0;  ///< The least recent delay (see kClockCheckMinS).
    bool clock_off = false;
    int64_t newest_removed_t_ns = INT64_MIN;  ///< Capture time of the newest sample that left the history.
    uint64_t evicted_uncalibrated = 0;
  };
  enum class State { kIncomplete, kComplete, kSkewed };
  struct Evaluation {
    State state = State::kIncomplete;
    std::map<int, const Sample*> members;  ///< Camera id -> chosen sample (when decided).
    std::vector<int> out_of_tolerance;     ///< Cameras whose nearest sample was too far...
    std::vector<int> running;              ///< ...of which these had frames on both sides, no pause between.
  };

  /// The camera's sample of frame `seq` (made if new); nullptr (counted as dropped,
  /// *why says why) if the frame arrived too late to be used.
  Sample* Slot(int camera_id, uint64_t seq, int64_t t_ns, uint64_t source_id, std::string* why);
  Evaluation Evaluate(const Sample& ref) const;
  /// Classifies a reference sample that will never be taken and counts it.
  void PassOver(const Sample& ref);
  void RemoveSample(int camera_id, Cam& cam, std::deque<Sample>::iterator it);
  void Prune();
  void ForgetCamera(int camera_id, Cam& cam, const std::string& reason);
  /// The camera's measured frame period, or kDefaultPeriodS before it has one.
  static double PeriodS(const Cam& cam) { return cam.period_s > 0 ? cam.period_s : kDefaultPeriodS; }
  void CheckClock(int camera_id, Cam& cam, int64_t capture_time_ns, int64_t arrival_ns);
  int ReferenceId() const;
  bool Reject(std::string* why, std::string text);

  size_t max_pending_;
  bool want_images_;
  double tolerance_s_ = 0;
  std::map<int, Camera> cameras_;
  std::map<int, Cam> cams_;
  int expected_ = 0;
  Aabb workspace_;
  uint64_t taken_up_to_ = 0;
  int64_t taken_time_ns_ = 0;
  bool taken_any_ = false;
  uint64_t dropped_ = 0, rejected_ = 0, restarts_ = 0, dropped_for_skew_ = 0, calibrations_refused_ = 0;
  uint64_t reference_frames_ = 0, framesets_complete_ = 0;
};

}  // namespace hullpipe
