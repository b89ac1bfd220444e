// What a headset shows (docs/hmd.md, "Display"): render_node's composited
// eyes, each image matched to the view it was drawn for, paired left with
// right. An OpenXR projection layer carries, for each eye, the image and the
// pose and field of view it was drawn from; the runtime reprojects it to the
// head's pose at display time (the latency the paper's §5 measured between
// tracker and display is hidden this way, not removed). No DDS, no GL: the
// client converts the messages (dds/convert.h) and uploads the pair
// (xr_display.h).
//
// Pairing: render_node composites both eyes of one head pose from one
// frameset and numbers their ViewPoses pose_seq (left) and pose_seq + 1
// (right) (nodes/render_controller.h), so a pair is a left and a right image
// of one frame_seq whose pose_seqs are consecutive, all of one run
// (render_node's run id, docs/reliability.md): pose_seq restarts with a
// restarted render_node, and another run's images never pair with this run's
// poses.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/stereo_views.h"

namespace hullpipe::openxr {

/// Makes an image's pixels (a CompositedView's JPEG decoded): CV_8UC3, or empty
/// when it cannot (the maker says why). Called only for images handed out.
using DecodeImageFn = std::function<cv::Mat()>;

/// One eye's composited image and the view it was drawn for.
struct EyeImage {
  cv::Mat bgr;              ///< CV_8UC3, the CompositedView's decoded image (possibly smaller than the view).
  NovelView view;           ///< The ViewPose's view: its pose (rig's world, OpenCV eye axes) and intrinsics.
  uint64_t pose_seq = 0;    ///< ViewPose.pose_seq.
  uint64_t run_id = 0;      ///< The run of the ViewPose and the image.
  uint64_t frame_seq = 0;   ///< The frameset it shows.
  DecodeImageFn decode;     ///< Until handed out: what makes bgr (bgr empty until then).
};

/// Counts of what EyeImagePairs was given and could not use.
struct EyeImageCounts {
  uint64_t paired = 0;       ///< Pairs handed out by TakeNewPair.
  uint64_t no_pose = 0;      ///< Images whose ViewPose did not arrive while they waited.
  uint64_t not_an_eye = 0;   ///< Images or poses of the one view (VIEW_EYE_MONO): render_node not in stereo.
  uint64_t superseded = 0;   ///< Images replaced by a newer one of the same eye before a pair formed.
  uint64_t run_changes = 0;  ///< Times a pose of another run than the last pose's came (a restarted render_node).
  uint64_t decoded = 0;      ///< Images decoded: only those of pairs handed out.
  uint64_t undecodable = 0;  ///< Images of a pair whose decoding failed (the pair not handed out).
};

/// Pairs composited eye images with their poses and with each other. Not
/// thread-safe.
class EyeImagePairs {
 public:
  /// pose_history: how many ViewPoses are kept to match images against (the
  /// images arrive after their poses: render_node publishes the pose, then
  /// composites). At least 2.
  explicit EyeImagePairs(size_t pose_history = 64);
  /// A ViewPose render_node (run `run_id`) sent for this client's views.
  /// Poses of the one view are counted and dropped. A pose of another run than
  /// the last pose's starts that run afresh: what was kept of the other is
  /// dropped, and its pose_seqs no longer order the pairs.
  void AddPose(uint64_t run_id, uint64_t pose_seq, ViewEye eye, const NovelView& view);
  /// A CompositedView of run `run_id`, decoded by `decode` only if it is
  /// handed out in a pair (a newer image of its eye supersedes it unread). An
  /// image whose ViewPose (same run, pose_seq and eye) has not arrived (the two
  /// travel on different topics) waits for it, at most kPendingImages of them.
  /// Returns why an image cannot be shown ("" when none): this one is the one
  /// view's, or an older waiting one was pushed out with no such ViewPose.
  std::string AddImage(uint64_t run_id, uint64_t pose_seq, ViewEye eye, uint64_t frame_seq, DecodeImageFn decode);
  /// The same with the image already decoded.
  std::string AddImage(uint64_t run_id, uint64_t pose_seq, ViewEye eye, uint64_t frame_seq, const cv::Mat& bgr) {
    return AddImage(run_id, pose_seq, eye, frame_seq, [bgr] { return bgr; });
  }
  static constexpr size_t kPendingImages = 4;
  /// The newest pair not handed out before ([0] left, [1] right), decoded, or
  /// nullopt. A pair older than one already handed out is never handed out; an
  /// image that does not decode is dropped (counted) and its pair with it.
  std::optional<std::array<EyeImage, 2>> TakeNewPair();
  const EyeImageCounts& counts() const { return counts_; }

 private:
  size_t history_;
  std::optional<uint64_t> run_;                           // the last pose's run: every pose kept is of it
  std::map<std::pair<uint64_t, int>, NovelView> poses_;  // (pose_seq, eye) of run_
  std::deque<std::pair<uint64_t, int>> pose_order_;
  void Keep(EyeImage image, int k);
  std::array<std::optional<EyeImage>, 2> newest_;  // per eye, not yet paired
  std::deque<std::pair<int, EyeImage>> pending_;   // (eye, image) waiting for its ViewPose (any run)
  std::optional<uint64_t> last_pair_left_seq_;  // of the last pair handed out
  EyeImageCounts counts_;
};

}  // namespace hullpipe::openxr
