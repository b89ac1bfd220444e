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
// Errors: CalibrationError with the file and the missing/bad key named.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "hullpipe/geometry/aabb.h"
#include "hullpipe/geometry/camera.h"

namespace hullpipe {

/// A calibration or rig file that cannot be used; what() names file and key.
class CalibrationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Reads one Utrecht-style config.xml into a Camera: converts mm -> m and OpenCV
/// pixel centres -> hullpipe (+0.5). width/height must be supplied (from the video).
/// Throws CalibrationError on a missing file, missing key or wrong matrix shape,
/// an image side outside [1, Camera::kMaxSide], and a CameraMatrix that is not
/// [fx 0 cx; 0 fy cy; 0 0 1] (skew, a wrong last row), whose fx or fy is outside
/// [0.01, 10^4] x width (singular), or whose principal point is outside the image.
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
  /// frame's source time) giving its pose per frame; empty: a fixed camera. YAML
  /// key `tracked`.
  std::string tracked;
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
  /// give it as `workspace: {min: [x,y,z], max: [x,y,z]}`; otherwise
  /// DefaultWorkspace of the cameras. For the Utrecht layout the floor (z = 0, the
  /// plane of the calibration board; z points down) bounds it: max z = 0.02.
  Aabb workspace;
  std::vector<Camera> Cameras() const;
};

/// Loads a rig from a Utrecht-layout directory or a generic YAML rig file.
/// Video sizes are probed with OpenCV; a camera whose video cannot be opened gets
/// its size from the background image/video, else CalibrationError. YAML rig
/// files: unknown keys are refused (named), at most Rig::kMaxCameras cameras, and
/// each camera's `K` is checked as ReadOpenCvCameraConfig checks CameraMatrix.
Rig LoadRig(const std::string& path);

/// Writes a rig as a generic YAML rig file (paths written as given). Used by tools
/// and tests to round-trip calibrations.
void WriteRigYaml(const Rig& rig, const std::string& path);

}  // namespace hullpipe
