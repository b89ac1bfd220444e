// Readers for calibrated rigs. Two formats:
//   1. The Utrecht rig layout: a directory with cam1..camN/, each holding
//      config.xml (OpenCV FileStorage: CameraMatrix 3x3, DistortionCoeffs 1x5 or 5x1,
//      Rotation as a Rodrigues 3-vector and Translation 3-vector in millimetres,
//      cam_from_world), background.avi, video.avi. The image size comes from the
//      videos (config.xml does not store it).
//   2. A generic rig file (YAML), all lengths in metres, K in OpenCV pixels:
//        cameras:
//          - id: 1
//            width: 644
//            height: 486
//            K: [fx, 0, cx, 0, fy, cy, 0, 0, 1]     # row-major, OpenCV pixel centres
//            distortion: [k1, k2, p1, p2, k3]      # optional, default zeros
//            R: [r00, r01, ..., r22]               # cam_from_world rotation, row-major
//            t: [tx, ty, tz]                       # cam_from_world translation, metres
//            background: cam1/background.avi      # video or image; relative to the file
//            frames: cam1/video.avi               # video, or printf pattern of images
//            masks: cam1/mask_%04d.png            # optional: ready-made object-pixel maps
//            mask_threshold: 128                  # object iff the mask value >= this (1..255)
//            mask_channel: luma                   # luma | alpha | red | green | blue (colour masks)
//        world:                                   # optional; derived from the cameras where absent
//          up: [0, 0, -1]                         # world up (gravity along -up)
//          floor: 0.0                             # plane up . x = floor; or "hull" (under the first
//                                                 # hull) or "none"
//          orbit_radius: 3.0                      # viewer's orbit around the hull, metres
//          orbit_height: 0.7                      # eye height above the hull's centre, metres
//        workspace: {min: [x, y, z], max: [x, y, z]}
// Image sequences (frames, background, masks as printf patterns such as
// img_%04d.png): the first file may be numbered 0 to 4 (OpenCV's image-sequence
// reader looks for the first of those), the numbers must then run on without a
// gap, and a frame's index (capture_node --frames, vh_eval --frame) counts
// positions in the sequence from 0, not the numbers in the names. docs/rigs.md.
// Rotations: a rotation orthonormal only to kRotationRepairTolerance (printed
// decimals) is replaced by the nearest rotation (SVD) and the correction logged
// once per rig (Rig::notes); anything farther from a rotation is refused.
// Errors: CalibrationError with the file and the missing/bad key named.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "hullpipe/geometry/aabb.h"
#include "hullpipe/geometry/camera.h"
#include "hullpipe/geometry/rig_world.h"

namespace hullpipe {

/// A calibration or rig file that cannot be used; what() names file and key.
class CalibrationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Largest coordinate a rig file may state for its workspace, floor and orbit:
/// 10 km from the origin, beyond any space a camera rig covers (a rig in other
/// units is imported with --scale); a 1e308 orbit or a NaN box passed before.
constexpr double kMaxStatedExtentM = 1e4;

/// Deepest nesting of sequences and maps ([ and {) accepted in a YAML or JSON
/// calibration file: OpenCV 4.6's FileStorage parser recurses once per level
/// and overflows the stack between 30,000 and 40,000 levels; a calibration
/// nests three or four.
constexpr int kMaxStorageNesting = 64;
/// Most sequences and maps in one such file (a bound on that recursion that
/// quotes cannot hide): a 64-camera calibration has a few hundred.
constexpr int kMaxStorageCollections = 4096;

/// Longest OpenCV may take to parse a YAML or JSON calibration file in the
/// bounded child process (CheckOpenCvStorageText): a 1-MiB file parses in
/// milliseconds, even under a sanitizer.
constexpr int kMaxStorageParseSeconds = 5;

/// Checks the text of a file for OpenCV's FileStorage before OpenCV parses it
/// (docs/reliability.md): at most 1 MiB, no NUL byte, XML (first character '<')
/// well-formed by libxml2 (no network, no DTD: OpenCV 4.6 dereferences NULL on
/// attributes cut short), YAML or JSON nested at most kMaxStorageNesting deep
/// with at most kMaxStorageCollections sequences and maps, and parsed once by
/// OpenCV in a child process that must end within kMaxStorageParseSeconds and
/// not by a signal (OpenCV 4.6's YAML parser loops forever on some malformed
/// text). Costs a fork (about a millisecond) per YAML or JSON file.
/// Throws CalibrationError naming `path` and what is wrong.
void CheckOpenCvStorageText(const std::string& text, const std::string& path);

/// Largest ||R R^T - I||_F (and |det R - 1|) accepted as a rotation and repaired
/// to the nearest one: 1e-3, a thousand times what six printed decimals leave and
/// well below anything that is not meant as a rotation (a reflection, a scaled or
/// transposed-wrong matrix is off by more than 0.1).
inline constexpr double kRotationRepairTolerance = 1e-3;

/// The nearest rotation to `r` (SVD: U V^T, det +1) when r is within
/// kRotationRepairTolerance of one; *error gets ||R R^T - I||_F. Throws
/// CalibrationError("<where>: ... not a rotation ...") otherwise, or when r is
/// not finite. Exact rotations come back unchanged.
Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& r, const std::string& where, double* error = nullptr);

/// A rotation orthonormal to better than this (||R R^T - I||_F) is repaired
/// without a note: that is what printing a rotation with 7 or more significant
/// digits leaves (2e-12 is typical), not a calibration worth a warning.
inline constexpr double kRotationNoteAbove = 1e-6;

/// The one line logged for a rig whose rotations were repaired by more than
/// kRotationNoteAbove: the cameras (id, ||R R^T - I||) and the worst error,
/// "<source>: the rotations of ...".
std::string RepairedRotationsNote(const std::string& source, const std::vector<std::pair<int, double>>& repaired);

/// Sets c's fx, fy, cx, cy and skew from a row-major 3x3 K (c's id, width,
/// height set), adding `offset` to the principal point (kOpenCvToHullpipePixelOffset
/// for files with pixel centres at integers, 0 for COLMAP's and hullpipe's; the
/// skew needs no offset). Throws CalibrationError("<path>: camera N: key '<key>'
/// ...") for a last row other than (0 0 1), fx or fy outside [0.01, 10^4] x
/// width, |skew| > fx, a principal point outside the image.
void SetCameraIntrinsics(const std::vector<double>& k, double offset, const std::string& path,
                         const std::string& key, Camera* c);

/// Reads one Utrecht-style config.xml into a Camera: converts mm -> m and OpenCV
/// pixel centres -> hullpipe (+0.5). width/height must be supplied (from the video).
/// Throws CalibrationError on a missing file, missing key or wrong matrix shape,
/// an image side outside [1, Camera::kMaxSide], and a CameraMatrix that is not
/// [fx s cx; 0 fy cy; 0 0 1] (a wrong last row), whose fx or fy is outside
/// [0.01, 10^4] x width (singular), whose skew s exceeds fx, or whose principal
/// point is outside the image.
Camera ReadOpenCvCameraConfig(const std::string& path, int camera_id, int width, int height);

/// One camera of a rig with the paths of its inputs (empty where absent).
struct RigCamera {
  Camera camera;
  std::string background;  ///< Empty-scene video or image for the background model.
  std::string frames;      ///< Live-scene video, or printf-style image pattern.
  std::string masks;       ///< Optional ready-made object-pixel maps (printf pattern).
  /// Live cameras (frames "v4l2:N" or a stream URL such as udp://, rtsp://, http://):
  /// seconds from the moment a frame was exposed to its arrival in capture_node
  /// (the camera's and the network's delay), subtracted from the arrival time to
  /// stamp the frame; [0, 10]. YAML key `latency`.
  double latency_s = 0;
  /// A tracked camera (paper §5: the one on the head-mounted display): a pose log
  /// in the head-pose CSV format (geometry/head_pose.h; world_from_camera, t = the
  /// frame's source time) giving its pose per frame; or kTrackedByTopic: its
  /// poses come live on hullpipe's CameraPose topic (a tracker, or hullpipe_ros2
  /// from a ROS 2 pose), sampled at each frame's capture time
  /// (capture/live_pose_track.h); empty: a fixed camera. YAML key `tracked`.
  std::string tracked;
  static constexpr const char* kTrackedByTopic = "topic";
  bool tracked_by_topic() const { return tracked == kTrackedByTopic; }
  /// Ready-made masks: a pixel is object iff its value (after taking the channel)
  /// is >= mask_threshold, in [1, 255]. YAML key `mask_threshold`; default 128
  /// (published masks are 0/255, and some carry background values up to ~25).
  int mask_threshold = 128;
  /// Which channel of a colour mask holds it: luma (BGR to grey), alpha, red,
  /// green, blue; a one-channel mask is itself. A 4-channel mask needs it said
  /// (luma or alpha), as either could be meant. YAML key `mask_channel`.
  enum class MaskChannel { kUnset, kLuma, kAlpha, kRed, kGreen, kBlue };
  MaskChannel mask_channel = MaskChannel::kUnset;
  /// True if `frames` is a live source rather than a file.
  bool live() const { return IsLiveSpec(frames); }
  /// True for "v4l2:N" and URLs ("scheme://...").
  static bool IsLiveSpec(const std::string& spec);
};

/// A calibrated rig: its cameras in id order.
struct Rig {
  /// Most cameras a rig file may list (the paper used 4; a frameset holds at most 64).
  static constexpr int kMaxCameras = 64;
  std::string source;  ///< Path it was loaded from.
  std::vector<RigCamera> cameras;
  /// World box (metres) outside which nothing is real object. Generic rig files may
  /// give it as `workspace: {min: [x,y,z], max: [x,y,z]}`; otherwise the box of
  /// what every camera sees (CommonViewWorkspace), or DefaultWorkspace of the
  /// cameras where they share no view. For the Utrecht layout the floor (z = 0, the
  /// plane of the calibration board; z points down) bounds it: max z = 0.02.
  Aabb workspace;
  /// Up, floor and orbit (rig_world.h): stated under `world:`, else derived
  /// (up from the cameras, floor under the first hull, an orbit framing the
  /// workspace). The Utrecht layout states its own: the calibration board is the
  /// floor (z = 0) and z points down, or up if the cameras say so.
  RigWorld world;
  /// What loading changed or assumed, one line each (repaired rotations, a
  /// z-up Utrecht calibration); also logged once as a warning.
  std::vector<std::string> notes;
  std::vector<Camera> Cameras() const;
};

/// Loads a rig from a Utrecht-layout directory or a generic YAML rig file.
/// Video sizes are probed with OpenCV; a camera whose video cannot be opened gets
/// its size from the background image/video, else CalibrationError. YAML rig
/// files: unknown keys are refused (named), at most Rig::kMaxCameras cameras, and
/// each camera's `K` is checked as ReadOpenCvCameraConfig checks CameraMatrix.
/// Without a stated workspace: CompleteRig's.
Rig LoadRig(const std::string& path);

/// Fills what the rig file did not state: workspace (CommonViewWorkspace: what
/// every camera sees; in the box around a ring's cameras a kUnknown hull's box
/// reaches out to the cameras; DefaultWorkspace with a note where the cameras
/// share no view), world
/// up (DeriveUp), orbit (FramingRadius of CommonViewWorkspace, what every camera
/// sees; height 0.25 x radius).
/// Used by LoadRig and by the importers.
void CompleteRig(Rig* rig);

/// The text of a mask channel ("luma"...) and back (nullopt if unknown).
std::string MaskChannelName(RigCamera::MaskChannel c);

/// Turns one ready-made mask image (1, 3 or 4 channels, 8 or 16 bit) into an
/// object-pixel map (CV_8UC1, 0/255) by rc's channel and threshold. Throws
/// std::invalid_argument naming the camera when the channel is not said for a
/// 4-channel mask, or the image has another channel count or depth.
cv::Mat MaskToObjectPixelMap(const cv::Mat& mask, const RigCamera& rc);

/// Every camera id of `rig` in [0, 2^31 - 1] and none twice: two cameras of
/// one id are one camera to the frameset assembler (a COLMAP model with a
/// duplicate IMAGE_ID imported with "no warnings" and composited nothing).
/// Throws CalibrationError naming `where` and the id.
void CheckCameraIds(const Rig& rig, const std::string& where);

/// Writes a rig as a generic YAML rig file (paths written as given). Used by tools
/// and tests to round-trip calibrations. Throws CalibrationError naming `path`
/// when it cannot be opened or written in full (a full disk).
void WriteRigYaml(const Rig& rig, const std::string& path);

}  // namespace hullpipe
