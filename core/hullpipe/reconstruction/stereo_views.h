// Per-eye views for a head-mounted display (paper §3: the participant wore a
// tracked HMD, and the parent pipe rendered for the tracked head). Each eye is
// a NovelView with its own pose and its own off-axis (asymmetric) frustum, in
// the convention HMD runtimes report them each frame (OpenXR's xrLocateViews:
// an XrPosef and an XrFovf per view), so a thin OpenXR client can feed
// hullpipe without hullpipe linking a runtime (docs/hmd.md).
//
// Frames: the eye frame is OpenCV's (x right, y down, z forward; geometry/
// conventions.h), as every NovelView's. OpenXR's view frame is x right, y up,
// z backward: the two differ by a half turn about x (OpenXrAxesInOpenCv).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "hullpipe/geometry/head_pose.h"
#include "hullpipe/geometry/rigid3.h"
#include "hullpipe/reconstruction/plane_sweep.h"

namespace hullpipe {

/// One eye's field of view as OpenXR's XrFovf: the angles of the frustum's
/// four sides from the eye's forward axis, radians; left and down negative for
/// a frustum around the axis (either may be positive for a frustum wholly to
/// one side). Tangents of the angles bound the image: x/z in [tan left, tan
/// right], and up/forward in [tan down, tan up].
struct EyeFov {
  /// Defaults: a common headset's left eye (a Meta Quest 3's runtime reports
  /// about -54 deg left and 40 deg right for it), +-48 deg vertically.
  double left = -0.9425, right = 0.6981, up = 0.8378, down = -0.8378;
  /// Throws std::invalid_argument naming the field: not finite, each angle
  /// within (-89, 89) deg, left < right and down < up.
  void Check() const;
  /// The same frustum for the other eye (left and right swapped and negated).
  EyeFov Mirrored() const { return {-right, -left, up, down}; }
};

/// The view of one eye: `width` x `height` pixels spanning the frustum exactly
/// (pixel edges 0 and width at tan left and tan right; centres at +0.5), a
/// pinhole whose principal point is off centre where the frustum is
/// asymmetric: fx = width / (tan right - tan left), cx = -tan(left) fx,
/// fy = height / (tan up - tan down), cy = tan(up) fy. Throws
/// std::invalid_argument for a bad fov or size.
NovelView EyeView(const EyeFov& fov, int width, int height, const Rigid3d& world_from_eye);
/// EyeView's inverse: the XrFovf a pinhole view spans, its image's edges at
/// pixel 0 and width (height) through the intrinsics: left = atan(-cx / fx),
/// right = atan((width - cx) / fx), up = atan(cy / fy), down = atan((cy -
/// height) / fy). What an OpenXR projection layer's view says of an image
/// drawn for that view (docs/hmd.md, "Display"). Throws std::invalid_argument
/// when fx or fy is not positive or the result fails EyeFov::Check.
EyeFov FovOfView(const NovelView& view);

enum class Eye { kLeft = 0, kRight = 1 };

/// Which eye a published view is for, as the wire carries it (ViewPose.eye and
/// CompositedView.eye, idl/hullpipe.idl's VIEW_EYE_*): the one view of a
/// monitor, or a headset's left or right eye. Viewers give each eye its own
/// frame and topic (docs/hmd.md, "Both eyes downstream").
enum class ViewEye : uint8_t { kMono = 0, kLeft = 1, kRight = 2 };
/// The view eye of eye `k` of a frame's `n` views (n 1: kMono; n 2: k 0 left,
/// k 1 right).
inline ViewEye ViewEyeOf(size_t k, size_t n) {
  return n < 2 ? ViewEye::kMono : (k == 0 ? ViewEye::kLeft : ViewEye::kRight);
}
/// `base` named for `eye`, the one rule for every per-eye frame, topic and
/// file: `base` itself for the one view (kMono), else base + separator +
/// "left" or "right" ("hullpipe_view_left", "/foxglove/composited/left").
std::string ForEye(const std::string& base, ViewEye eye, char separator);

/// An eye's pose from the head's: the head's orientation, the eye ipd_m / 2
/// along the head's -x (left) or +x (right) axis (the eyes' views parallel, as
/// OpenXR runtimes report them for most headsets). world_from_head in the
/// OpenCV eye convention, its origin midway between the eyes.
Rigid3d WorldFromEye(const Rigid3d& world_from_head, Eye eye, double ipd_m);

/// render_node --stereo's settings.
struct StereoOptions {
  double ipd_m = 0.064;               ///< Interpupillary distance, metres, [0.04, 0.09] (--ipd).
  EyeFov left;                        ///< --fov-left (four angles, radians)
  EyeFov right = EyeFov{}.Mirrored();  ///< --fov-right
  int width = 320, height = 320;      ///< Each eye's image, pixels.
  /// Throws std::invalid_argument naming the flag.
  void Check() const;
};

/// Both eyes' views for one head pose.
struct StereoViews {
  std::array<NovelView, 2> eye;  ///< [Eye::kLeft], [Eye::kRight]
};
StereoViews MakeStereoViews(const Rigid3d& world_from_head, const StereoOptions& options);

/// OpenXR's view axes (x right, y up, z backward) in OpenCV's eye axes (x
/// right, y down, z forward): diag(1, -1, -1), a half turn about x. An
/// XrPosef's world_from_view rotation R_xr is world_from_eye R_xr diag(1,-1,-1).
Eigen::Matrix3d OpenXrAxesInOpenCv();

/// An eye's pose from an OpenXR XrPosef: position (metres, in the rig's world)
/// and orientation (x, y, z, w; OpenXR's view axes, any non-zero length), as
/// world_from_eye in OpenCV's eye axes: R = R_xr diag(1, -1, -1). Throws
/// std::invalid_argument for a value not finite or a zero quaternion.
Rigid3d EyePoseFromXr(const Eigen::Vector3d& position, const Eigen::Vector4d& orientation_xyzw);
/// The XrPosef orientation (x, y, z, w; unit) of world_from_eye's rotation
/// (OpenCV eye axes): EyePoseFromXr's inverse.
Eigen::Vector4d XrOrientationOf(const Rigid3d& world_from_eye);

/// Both eyes at one time as an HMD runtime reports them (one xrLocateViews):
/// the EyeViews topic's sample (render_node --view eyes-topic, docs/hmd.md).
struct EyeViewsSample {
  uint32_t tracker_id = 0;
  int64_t stamp_ns = 0;                   ///< When the views hold (CLOCK_REALTIME ns).
  std::array<Rigid3d, 2> world_from_eye;  ///< [Eye::kLeft], [Eye::kRight]; OpenCV eye axes, metres.
  std::array<EyeFov, 2> fov;              ///< Each eye's XrFovf.
};

/// Per-eye poses and fields of view over time, as an HMD runtime reports them
/// (a log of xrLocateViews), read from CSV rows
///   t, eye, px,py,pz, qx,qy,qz,qw, left,right,up,down
/// t seconds (the head-pose logs' clock: seconds from the input's first frame),
/// eye 0 (left) or 1 (right), p the eye's position in the rig's world (metres;
/// the lab's registration of the tracking space to the rig applied before), q
/// its orientation as an XrPosef's (x y z w; OpenXR's view axes, converted to
/// OpenCV's here), and the XrFovf angles (radians). Each eye's pose is
/// interpolated as a PoseTrack; its fov is the latest row's at or before t
/// (the first row's before it).
class StereoViewTrack {
 public:
  struct Row {
    double t = 0;
    Eye eye = Eye::kLeft;
    Rigid3d world_from_eye;  ///< OpenCV eye axes.
    EyeFov fov;
  };
  /// Throws std::invalid_argument: an eye with no row, a bad fov (naming the
  /// row's index), two rows of one eye at one time.
  explicit StereoViewTrack(std::vector<Row> rows);
  /// Eye `eye`'s view at time t, `width` x `height` pixels.
  NovelView At(double t, Eye eye, int width, int height) const;

 private:
  std::array<PoseTrack, 2> poses_;
  std::array<std::vector<std::pair<double, EyeFov>>, 2> fovs_;  // by time
};

/// Reads a per-eye view CSV (format above; a first line that is not numbers
/// is a header; '#' lines are comments). Throws std::runtime_error naming the
/// file and line: a wrong column count, a non-number, an eye not 0 or 1, a
/// zero quaternion, a bad fov, an eye with no row.
StereoViewTrack LoadStereoViewTrack(const std::string& path);

}  // namespace hullpipe
