// The built-in synthetic scene as a capture source (capture/rig_source.h): a
// named scene (synthetic.h) moving in front of ring or dome cameras, with exact
// object-pixel maps and shaded colour, no files needed. What a test or a
// benchmark feeds capture_node when the real rig's segmentation must not be in
// the way.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hullpipe/capture/rig_source.h"
#include "hullpipe/geometry/calibration.h"

namespace hullpipe {

/// Options of the synthetic source.
struct SyntheticRigOptions {
  /// Bounds (checked by OpenSyntheticRig): a 4096x4096 camera is 16 MB a map and
  /// image; 100000x100000 once grew past 9.8 GB without a word.
  static constexpr int kMaxSide = 4096, kMaxCameras = Rig::kMaxCameras;
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
