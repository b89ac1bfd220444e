// The test fixtures every core test shares: synthetic rigs of analytic shapes
// with exact object-pixel maps (evaluation/synthetic.h), the usual workspace,
// side views of the test sphere, and the real Utrecht rig beside the repository.
// Header-only; linked as hullpipe_testing (tests only).
#pragma once

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/geometry/rigid3.h"
#include "hullpipe/reconstruction/exact_hull.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/volume_query.h"
#include "hullpipe/segmentation/video_rig.h"

namespace hullpipe::test {

/// The test sphere most core tests look at (world metres, Utrecht-like: z down).
inline const Eigen::Vector3d kSphereCentre(0.1, -0.2, -1.0);
inline constexpr double kSphereRadius = 0.3;

/// The Utrecht rig's cam1 lens (its config.xml's k1 k2 p1 p2 k3, rounded): a
/// strong barrel, for tests that need a real lens without reading the rig.
inline constexpr Distortion kUtrechtCam1Lens{-0.369, 0.203, 3.3e-4, 1.8e-5, -0.0712};

/// The Utrecht rig beside the repository (../shared/data/utrecht-4cam).
inline std::string RigDir() { return HULLPIPE_RIG_DIR; }
inline bool HaveRig() { return std::filesystem::exists(RigDir() + "/cam1/config.xml"); }

#ifdef HULLPIPE_DOME_DIR
/// The real rigs beside the repository: the published 20-camera dome's YAML
/// rig (../shared/data/dome-20cam/rig.yaml) and the Utrecht rig's directory.
inline std::vector<std::string> RealRigs() { return {std::string(HULLPIPE_DOME_DIR) + "/rig.yaml", RigDir()}; }
#endif

/// A real rig's first frame: its source, the frame, and each camera's map as
/// the volume query takes them. `source` is null when the rig is not on disk
/// (no ../shared beside the clone): the caller skips.
struct RealRigFrame {
  std::unique_ptr<RigSource> source;
  RigFrame frame;
  std::vector<CameraMap> views;
};
inline RealRigFrame FirstFrameOf(const std::string& rig) {
  RealRigFrame f;
  if (!std::filesystem::is_regular_file(rig) && !std::filesystem::exists(rig + "/cam1/config.xml")) return f;
  f.source = OpenVideoRig(rig, {});
  if (!f.source->Next(&f.frame)) throw std::runtime_error(rig + ": no first frame");
  for (size_t i = 0; i < f.source->cameras().size(); ++i) f.views.push_back({f.source->cameras()[i], f.frame.maps[i]});
  return f;
}

/// A fresh temporary directory, unique to this process and call.
inline std::filesystem::path TempDir(const std::string& tag) {
  static std::atomic<int> counter{0};
  const auto p = std::filesystem::temp_directory_path() /
                 ("hullpipe_test_" + tag + "_" + std::to_string(getpid()) + "_" + std::to_string(counter++));
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p;
}

/// A workspace of 20 m on a side around the origin: constrains nothing in tests.
inline Aabb BigBox() {
  Aabb b;
  b.min = Eigen::Vector3d::Constant(-10);
  b.max = Eigen::Vector3d::Constant(10);
  return b;
}

/// Exact object-pixel maps of `scene` in each of `cams`.
inline std::vector<CameraMap> ExactViews(const std::vector<Camera>& cams, const SyntheticScene& scene) {
  std::vector<CameraMap> views;
  for (const auto& c : cams) views.push_back({c, RenderExactMap(c, scene)});
  return views;
}

/// The cameras with skew (K's row 0, column 1) of `fraction` x fx, the sign
/// alternating from camera to camera, as published calibrations have it (a few
/// pixels there; tests take more, so that dropping it shows).
inline std::vector<Camera> WithSkew(std::vector<Camera> cams, double fraction) {
  for (size_t i = 0; i < cams.size(); ++i) cams[i].skew = (i % 2 ? -fraction : fraction) * cams[i].fx;
  return cams;
}

/// n ring cameras (w x h, 60 degree fov, 3 m away, 1.8 m up) around a sphere of
/// radius r at `centre`, with exact object-pixel maps; skew as WithSkew.
inline std::vector<CameraMap> SphereViews(int n, int w, int h, const Eigen::Vector3d& centre, double r,
                                          const Distortion& d = {}, double skew_fraction = 0) {
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Sphere(centre, r));
  return ExactViews(WithSkew(RingCameras(n, 3.0, 1.8, centre, w, h, 1.0, d), skew_fraction), scene);
}

/// The visual hull of `scene` seen by `cams` with exact maps, in BigBox().
inline VolumeQuery HullOf(const SyntheticScene& scene, const std::vector<Camera>& cams,
                          const VolumeQueryOptions& options = {}) {
  return VolumeQuery(ExactViews(cams, scene), BigBox(), options);
}

/// A camera at `eye` looking at `target` with world up (0,0,-1) (z down).
inline Camera LookAtCamera(int id, const Eigen::Vector3d& eye, const Eigen::Vector3d& target, int w, int h,
                           double hfov) {
  return LookingCamera(id, eye, target, Eigen::Vector3d(0, 0, -1), w, h, hfov);
}

/// A novel view (w x h, 0.8 rad fov) from the side of the test sphere, above it.
inline NovelView SphereSideView(int w = 160, int h = 120) {
  return NovelView::FromFov(
      w, h, 0.8, LookAt(kSphereCentre + Eigen::Vector3d(2.0, 1.2, -0.5), kSphereCentre, Eigen::Vector3d(0, 0, -1)));
}

/// Whether ray parameter s lies in one of the exact ray–hull intervals.
inline bool InIntervals(const Intervals& iv, double s) {
  for (const auto& [a, b] : iv)
    if (s >= a && s <= b) return true;
  return false;
}

/// Distance from s to the nearest interval end (+inf for no intervals).
inline double DistanceToBoundary(const Intervals& iv, double s) {
  double d = std::numeric_limits<double>::infinity();
  for (const auto& [a, b] : iv) d = std::min({d, std::abs(s - a), std::abs(s - b)});
  return d;
}

/// The visual hull of the test sphere seen by four 320x240 ring cameras with
/// exact maps: the fixture of the volume query, sweep and triangle query tests.
class SphereHull : public ::testing::Test {
 protected:
  SphereHull() : query_(SphereViews(4, 320, 240, kSphereCentre, kSphereRadius), BigBox()) {}
  VolumeQuery query_;
};

/// Writes an axis-aligned cube of half size h centred at c (metres) as OBJ
/// object `name`, its faces wound outward; its vertex indices start at base + 1
/// (base: the vertices written before it in the same file).
inline void WriteObjCube(std::ostream& o, const std::string& name, const Eigen::Vector3d& c, double h, int base) {
  o << "o " << name << "\n";
  for (int k = 0; k < 8; ++k)
    o << "v " << c.x() + (k & 1 ? h : -h) << ' ' << c.y() + (k & 2 ? h : -h) << ' ' << c.z() + (k & 4 ? h : -h) << '\n';
  const int f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                        {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  for (const auto& t : f) o << "f " << base + t[0] + 1 << ' ' << base + t[1] + 1 << ' ' << base + t[2] + 1 << '\n';
}

/// Pixels of two CV_32FC1 depth images that differ (bit for bit, +inf equal
/// to +inf), and pixels of `reference` with a finite depth (a test's control
/// that the view sees the hull). Sizes must match.
struct DepthDifference {
  int differ = 0, hull = 0;
};
inline DepthDifference CompareDepths(const cv::Mat& a, const cv::Mat& reference) {
  DepthDifference d;
  for (int r = 0; r < a.rows; ++r)
    for (int c = 0; c < a.cols; ++c) {
      const float x = a.at<float>(r, c), y = reference.at<float>(r, c);
      d.hull += std::isfinite(y);
      d.differ += !(x == y || (std::isinf(x) && std::isinf(y)));
    }
  return d;
}

}  // namespace hullpipe::test
