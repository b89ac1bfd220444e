// A rig that is not the Utrecht one, written to disk as a lab would have it:
// the synthetic figure (AnimatedFigure) filmed by cameras on a ring, stored as
// videos (one per camera, plus an empty-scene background video) and a
// calibration in a world of its own: z up, the floor z = 0, the figure standing
// off the origin and turned about the vertical, as a calibration board laid on
// the floor somewhere in the room would put it. The calibration is written as
// COLMAP writes it (a text model: cameras.txt, images.txt, points3D.txt) or as
// hullpipe's YAML rig file (calibration.h). docs/rigs.md, "Another rig".
#pragma once

#include <string>
#include <vector>

#include "hullpipe/geometry/camera.h"
#include "hullpipe/geometry/rigid3.h"

namespace hullpipe {

/// What to film and how to store it.
struct SyntheticRigFilesOptions {
  int cameras = 8;          ///< On a ring around the figure, heights alternating; [3, 64].
  int width = 644;          ///< Image size in pixels (the Utrecht rig's by default); each side [16, 2048].
  int height = 486;
  int frames = 150;         ///< Video length in frames [1, 10000]; the figure waves with period 4 s.
  double fps = 25;          ///< Frames per second of the videos and of the figure's motion, (0, 120].
  int background_frames = 30;  ///< Empty-scene frames per background video [1, 1000].
  double noise_sigma = 2.0;    ///< Gaussian sensor noise per channel, grey levels [0, 50] (0: none).
  double k1 = -0.04;           ///< Radial distortion of every camera (COLMAP OPENCV model), [-0.5, 0.5].
  /// Skew of every camera, pixels (K's row 0, column 1; Camera::skew), |skew| <=
  /// 0.2 x fx. Only with format "yaml": COLMAP's camera models have no skew.
  double skew = 0;
  double ring_radius = 3.2;    ///< Camera distance from the figure's vertical axis, metres [1.5, 20].
  std::string format = "colmap";  ///< "colmap" (text model under sparse/0) or "yaml" (rig.yaml).
  int threads = 2;             ///< Cameras rendered in parallel [1, 64].
  unsigned seed = 1;           ///< Noise seed (the files are reproducible).
  /// Throws std::invalid_argument naming the field for a value outside its range.
  void Check() const;
};

/// What was written.
struct SyntheticRigFiles {
  /// The cameras in the written world (cam_from_world as stored in the
  /// calibration), ids 1..n.
  std::vector<Camera> cameras;
  /// world_from_figure: the figure's frame (AnimatedFigure's: z down, floor z = 0,
  /// the figure's axis through the origin) in the written world (z up, floor z = 0).
  Rigid3d world_from_figure;
  std::string calibration;  ///< sparse/0 directory (colmap) or rig.yaml (yaml).
  std::string frames_pattern;      ///< "videos/cam{id}.avi", relative to the output directory.
  std::string background_pattern;  ///< "videos/cam{id}_background.avi".
};

/// The written world's pose of the figure: it stands at (1.5, -0.8, 0) on the
/// floor z = 0, z up, turned 30 degrees about z. Exact: a rotation of 180 degrees
/// about x (z down to z up) then 30 degrees about z, then the translation.
Rigid3d SyntheticRigWorldFromFigure();

/// Renders AnimatedFigure(k / fps) for k in [0, frames) from options.cameras
/// cameras (RenderColour, plus noise) and writes, under `dir` (created):
///   videos/cam<id>.avi, videos/cam<id>_background.avi  (MJPG, options.fps)
///   colmap: sparse/0/{cameras,images,points3D}.txt (model OPENCV: fx fy cx cy k1
///           k2 p1 p2; images named images/cam<id>.png, the first frame, also
///           written); yaml: rig.yaml (frames and background set relative to it,
///           the world and workspace derived by CompleteRig and stated).
/// Throws std::invalid_argument (options), std::runtime_error naming the file
/// that could not be written.
SyntheticRigFiles WriteSyntheticRigFiles(const SyntheticRigFilesOptions& options, const std::string& dir);

}  // namespace hullpipe
