// Importers of rigs as the field calibrates them, into hullpipe's Rig (written
// out as the generic rig file by `hullpipe_rig import`). Each converts at its
// boundary what its format does differently (docs/rigs.md, "Importing a rig"):
//
//   format       extrinsics              camera axes   pixel centres   units
//   colmap       cam_from_world (qvec,t) OpenCV        +0.5 (as ours)  model units
//   nerf         world_from_camera 4x4   OpenGL (y up, z back)  +0.5   scene units
//   middlebury   cam_from_world (R, t)   OpenCV        integers        metres
//   opencv-yaml  multicalib camera_pose_i or stereo R,T: cam_from_world (ref. camera = world)
//                                        OpenCV        integers        pattern units
//   pmvs         P = K [R t] (3x4, any scale), decomposed       integers        scene units
//
// "model/scene/pattern units" are multiplied by ImportOptions::scale (metres
// per unit). Rotations within kRotationRepairTolerance of one are repaired to the
// nearest (logged once in Rig::notes), quaternions normalised when within it of
// unit length; anything else is refused. Camera models other than the
// pinhole with OpenCV's k1 k2 p1 p2 k3 are refused naming the model and camera.
// The world is then completed as LoadRig does (CompleteRig).
// Errors: CalibrationError naming the file, the camera or line, and the key.
#pragma once

#include <string>

#include <Eigen/Core>

#include "hullpipe/geometry/calibration.h"

namespace hullpipe {

/// Options of every importer.
struct ImportOptions {
  /// Metres per unit of the file's lengths (0.001 for millimetres); > 0.
  double scale = 1.0;
  /// Image size for formats that may not store it (nerf without w/h, middlebury,
  /// opencv-yaml without image_width/height); 0: read it from the camera's image.
  int width = 0, height = 0;
  /// opencv-yaml: the file's poses are world_from_camera rather than cam_from_world.
  bool poses_world_from_camera = false;
  /// Throws std::invalid_argument naming the option.
  void Check() const;
};

/// COLMAP sparse model: a directory with cameras.txt and images.txt, or
/// cameras.bin and images.bin (text first). One hullpipe camera per registered
/// image, id = IMAGE_ID, frames = the image's path under `<dir>/../images/` if
/// it exists there, else beside the model. Camera models: SIMPLE_PINHOLE,
/// PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV (k4..k6 zero); others
/// refused. At most Rig::kMaxCameras images.
Rig ImportColmap(const std::string& dir, const ImportOptions& options = {});

/// NeRF transforms.json (original NeRF, instant-ngp, nerfstudio keys):
/// camera_angle_x or fl_x/fl_y, optional cx, cy (default the image centre), w,
/// h, k1, k2, p1, p2, k3, per frame or global; frames[].transform_matrix is
/// world_from_camera with OpenGL axes (x right, y up, z backwards). Ids 1..N in
/// file order; frames = file_path (".png" added when it has no extension).
Rig ImportNerf(const std::string& path, const ImportOptions& options = {});

/// Middlebury multi-view `*_par.txt`: a count line, then per image
/// `name k11..k33 r11..r33 t1 t2 t3` (x = K [R t] X). Ids 1..N; frames = name
/// beside the file.
Rig ImportMiddlebury(const std::string& path, const ImportOptions& options = {});

/// OpenCV FileStorage YAML/XML: either a multi-camera calibration (opencv_contrib
/// ccalib: nCameras, camera_matrix_i, camera_distortion_i, camera_pose_i as 4x4,
/// i from 0; ids i + 1) or a stereo calibration (M1, D1, M2, D2, R, T: camera 2
/// from camera 1; ids 1, 2; a directory holding intrinsics.yml and extrinsics.yml
/// as OpenCV's stereo_calib sample writes them is read as one). image_width and
/// image_height keys give the size where present.
Rig ImportOpenCvYaml(const std::string& path, const ImportOptions& options = {});

/// Decomposes a projection matrix P (3x4, x = P X, known up to scale and sign)
/// into K (upper triangular, positive diagonal, K(2,2) = 1: skew included), a
/// rotation R and t with P ~ K [R | t] (RQ decomposition). False if P is not
/// finite or its left 3x3 is singular (no camera centre).
bool DecomposeProjection(const Eigen::Matrix<double, 3, 4>& P, Eigen::Matrix3d* K, Eigen::Matrix3d* R,
                         Eigen::Vector3d* t);

/// PMVS/CMVS cameras (as VisualSFM and COLMAP export them, and multi-view data
/// sets that give 3x4 projection matrices): `<dir>/txt/*.txt` (or a directory
/// of them), each "CONTOUR" then P's 12 numbers row by row; images as
/// `<dir>/visualize/<name>.jpg|ppm|png`. Ids 1..N in file-name order. P is
/// decomposed (DecomposeProjection); its skew is kept. Pixel centres at integers
/// (PMVS samples images there). Lengths in scene units (ImportOptions::scale).
Rig ImportPmvs(const std::string& path, const ImportOptions& options = {});

/// Dispatches on `format`: colmap, nerf, middlebury, opencv-yaml, pmvs. Throws
/// CalibrationError for an unknown format.
Rig ImportRig(const std::string& format, const std::string& path, const ImportOptions& options = {});

}  // namespace hullpipe
