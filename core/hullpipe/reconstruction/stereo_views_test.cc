// Per-eye views (stereo_views.h) against exact ground truth: the frustum's
// sides land on the image's edges, the two eyes' images of one point differ by
// the stereo disparity fx ipd / z, each eye's refined sweep equals the exact
// ray-hull depth from that eye's off-axis view, and a per-eye log in OpenXR's
// convention reads back the poses and fields of view it holds.
#include "hullpipe/reconstruction/stereo_views.h"

#include <cmath>
#include <filesystem>
#include <fstream>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "hullpipe/reconstruction/exact_hull.h"
#include "hullpipe/testing/fixtures.h"
#include "hullpipe/util/percentile.h"

namespace hullpipe {
namespace {

using test::kSphereCentre;
using test::kSphereRadius;

// Pixel (u, v) of eye-frame point p (hullpipe's pixel convention: edges at 0
// and width).
Eigen::Vector2d Project(const NovelView& v, const Eigen::Vector3d& p_eye) {
  return {v.fx * p_eye.x() / p_eye.z() + v.cx, v.fy * p_eye.y() / p_eye.z() + v.cy};
}

TEST(EyeView, TheFrustumsSidesAreTheImagesEdges) {
  const EyeFov fov{-0.9, 0.6, 0.8, -0.7};
  const NovelView v = EyeView(fov, 400, 300, Rigid3d{});
  // A point on each side plane of the frustum, 2 m ahead.
  EXPECT_NEAR(Project(v, {2 * std::tan(fov.left), 0.1, 2}).x(), 0.0, 1e-12);
  EXPECT_NEAR(Project(v, {2 * std::tan(fov.right), 0.1, 2}).x(), 400.0, 1e-12);
  EXPECT_NEAR(Project(v, {0.1, -2 * std::tan(fov.up), 2}).y(), 0.0, 1e-12);  // up is -y in OpenCV's frame
  EXPECT_NEAR(Project(v, {0.1, -2 * std::tan(fov.down), 2}).y(), 300.0, 1e-12);
  // The forward axis is off centre: left of it is wider (tan 0.9 > tan 0.6).
  EXPECT_GT(v.cx, 200.0);
  // A symmetric frustum is the centred pinhole of that field of view.
  const NovelView s = EyeView({-0.4, 0.4, 0.3, -0.3}, 320, 240, Rigid3d{});
  const NovelView c = NovelView::FromFov(320, 240, 0.8, Rigid3d{});
  EXPECT_NEAR(s.fx, c.fx, 1e-9);
  EXPECT_NEAR(s.cx, 160.0, 1e-12);
  EXPECT_NEAR(s.cy, 120.0, 1e-12);
  EXPECT_THROW(EyeView({0.5, 0.4, 0.3, -0.3}, 320, 240, Rigid3d{}), std::invalid_argument);  // left > right
  EXPECT_THROW(EyeView({-0.4, 0.4, 1.6, -0.3}, 320, 240, Rigid3d{}), std::invalid_argument);  // 92 deg
  EXPECT_THROW(EyeView({-0.4, 0.4, std::nan(""), -0.3}, 320, 240, Rigid3d{}), std::invalid_argument);
}

// FovOfView is EyeView's inverse (the fov a projection layer reports for an
// image), including a frustum wholly to one side and a pinhole not made by
// EyeView; round-trip error is atan's rounding (1e-12 rad).
TEST(EyeView, FovOfViewGivesBackTheFrustum) {
  for (const EyeFov& fov :
       {EyeFov{}, EyeFov{}.Mirrored(), EyeFov{0.1, 0.7, 0.5, -0.2}, EyeFov{-0.9, 0.6, -0.1, -0.7}}) {
    const EyeFov back = FovOfView(EyeView(fov, 333, 217, Rigid3d{}));
    EXPECT_NEAR(back.left, fov.left, 1e-12);
    EXPECT_NEAR(back.right, fov.right, 1e-12);
    EXPECT_NEAR(back.up, fov.up, 1e-12);
    EXPECT_NEAR(back.down, fov.down, 1e-12);
  }
  const EyeFov c = FovOfView(NovelView::FromFov(320, 240, 0.8, Rigid3d{}));  // symmetric, 0.8 rad across
  EXPECT_NEAR(c.right - c.left, 0.8, 1e-12);
  EXPECT_NEAR(c.left, -c.right, 1e-12);
  NovelView bad = NovelView::FromFov(320, 240, 0.8, Rigid3d{});
  bad.fx = 0;
  EXPECT_THROW(FovOfView(bad), std::invalid_argument);
}

// The eyes sit ipd/2 either side of the head along its x axis, parallel: a
// point z ahead shows in the two images ipd fx / z apart (after each eye's
// principal point), exactly.
TEST(StereoViews, TheEyesImagesOfAPointDifferByTheStereoDisparity) {
  Rigid3d head;
  head.rotation = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  head.translation = Eigen::Vector3d(0.4, -0.1, -1.6);
  StereoOptions o;
  o.width = o.height = 500;
  const StereoViews v = MakeStereoViews(head, o);
  EXPECT_NEAR((v.eye[1].world_from_eye.translation - v.eye[0].world_from_eye.translation).norm(), 0.064, 1e-15);
  EXPECT_NEAR((head.rotation.transpose() * (v.eye[1].world_from_eye.translation - head.translation)).x(), 0.032,
              1e-15);
  for (const double z : {0.3, 1.0, 4.0}) {
    const Eigen::Vector3d p_world = head.rotation * Eigen::Vector3d(0.05, -0.02, z) + head.translation;
    const Eigen::Vector2d l = Project(v.eye[0], v.eye[0].world_from_eye.Inverse() * p_world);
    const Eigen::Vector2d r = Project(v.eye[1], v.eye[1].world_from_eye.Inverse() * p_world);
    EXPECT_NEAR((l.x() - v.eye[0].cx) - (r.x() - v.eye[1].cx), v.eye[0].fx * 0.064 / z, 1e-9) << z;
    EXPECT_NEAR(l.y(), r.y(), 1e-9) << "no vertical disparity between parallel eyes";
  }
}

// Each eye's sweep, refined, against the exact ray-hull depth of that eye's
// off-axis view (the one-view test, ExactHull.RefinementRemovesThePlaneSpacing-
// FromTheError, for both eyes of an asymmetric headset frustum); and the same
// surface point seen by both eyes: the exact entry along a left-eye pixel's ray
// is the exact entry along the right eye's ray to it, at the disparity of its depth.
TEST(StereoViews, EachEyesSweepIsTheExactHullFromThatEye) {
  const VolumeQuery q(test::SphereViews(4, 160, 120, kSphereCentre, kSphereRadius), test::BigBox());
  StereoOptions o;
  o.width = o.height = 200;
  o.left = {-0.5, 0.3, 0.35, -0.3};  // asymmetric both ways, narrow enough for the sphere to fill pixels
  o.right = o.left.Mirrored();
  const Rigid3d head = test::SphereSideView().world_from_eye;
  const StereoViews views = MakeStereoViews(head, o);
  ASSERT_GT(std::abs(views.eye[0].cx - 100.0), 20.0) << "an asymmetric frustum";
  std::array<cv::Mat, 2> exact;
  for (int k = 0; k < 2; ++k) {
    SCOPED_TRACE(k ? "right eye" : "left eye");
    const NovelView& view = views.eye[k];
    PlaneSweepOptions so;
    so.num_planes = 16;
    const auto depths = SweepPlaneDepths(q, view, so);
    const cv::Rect all(0, 0, view.width, view.height);
    exact[k] = ExactHullDepth(q, view, all);
    const cv::Mat refined = PlaneSweepCpu(q, view, depths, all, nullptr, 1, 12);
    std::vector<double> err;
    int mismatched = 0;
    for (int r = 0; r < view.height; ++r)
      for (int c = 0; c < view.width; ++c) {
        const float e = exact[k].at<float>(r, c), b = refined.at<float>(r, c);
        if (std::isfinite(e) != std::isfinite(b)) {
          ++mismatched;  // a silhouette pixel where the 16 planes miss a sliver
          continue;
        }
        if (!std::isfinite(e)) continue;
        EXPECT_GE(b, e - 1e-4);
        err.push_back(std::abs(double(b) - e));
      }
    ASSERT_GT(err.size(), 1000u);
    EXPECT_LT(Median(err), 1e-4);  // 0.1 mm: 12 bisections of 4.5 cm plus float rounding
    EXPECT_LE(mismatched, int(err.size()) / 50);
  }
  // The same surface points from both eyes.
  const NovelView& L = views.eye[0];
  const NovelView& R = views.eye[1];
  int both = 0, checked = 0;
  for (int r = 4; r < L.height; r += 10)
    for (int c = 4; c < L.width; c += 10) {
      const Eigen::Vector3d O = L.world_from_eye.translation,
                            D = L.world_from_eye.rotation * L.EyeRay(c + 0.5, r + 0.5);
      const Intervals iv = RayHullIntervals(q, O, D, 1e-6, 100);
      if (iv.empty()) continue;
      const Eigen::Vector3d X = O + iv.front().first * D;
      const Eigen::Vector3d X_right = R.world_from_eye.Inverse() * X;
      const Eigen::Vector2d uv = Project(R, X_right);
      if (uv.x() < 0 || uv.x() > R.width) continue;
      ++checked;
      const Eigen::Vector3d OR = R.world_from_eye.translation, DR = X - OR;
      const Intervals ir = RayHullIntervals(q, OR, DR, 1e-6, 2);
      if (ir.empty() || std::abs(ir.front().first - 1.0) * DR.norm() > 1e-9) continue;  // hidden from the right eye
      ++both;
      const double z = (L.world_from_eye.Inverse() * X).z();
      EXPECT_NEAR((c + 0.5 - L.cx) - (uv.x() - R.cx), L.fx * o.ipd_m / z, 1e-6);
    }
  ASSERT_GT(checked, 40);
  EXPECT_GE(both, checked * 9 / 10) << "a convex sphere: nearly every point one eye sees, the other sees";
}

// A per-eye log in OpenXR's convention: XrPosef orientations (view axes x
// right, y up, z back) become OpenCV eye frames; each eye's pose interpolates,
// its fov is the latest row's.
TEST(StereoViewTrack, ReadsXrPosesAndFovsPerEye) {
  const auto dir = std::filesystem::temp_directory_path() / "hullpipe_stereo_view_track";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "views.csv").string();
  {
    std::ofstream f(path);
    f << "t,eye,px,py,pz,qx,qy,qz,qw,left,right,up,down\n"
      << "0,0,-0.032,0,0,0,0,0,1,-0.9,0.7,0.8,-0.8\n"
      << "0,1,0.032,0,0,0,0,0,1,-0.7,0.9,0.8,-0.8\n"
      << "1,0,0.968,0,0,0,0,0,1,-0.8,0.7,0.8,-0.8\n"
      << "1,1,1.032,0,0,0,0,0,1,-0.7,0.9,0.8,-0.8\n";
  }
  const StereoViewTrack track = LoadStereoViewTrack(path);
  const NovelView l = track.At(0.25, Eye::kLeft, 100, 100);
  EXPECT_NEAR(l.world_from_eye.translation.x(), 0.218, 1e-12);
  // The identity XrPosef looks along OpenXR's -z with y up: OpenCV's z forward
  // is the world's -z, its y (down) the world's -y.
  EXPECT_NEAR((l.world_from_eye.rotation * Eigen::Vector3d::UnitZ() - Eigen::Vector3d(0, 0, -1)).norm(), 0, 1e-15);
  EXPECT_NEAR((l.world_from_eye.rotation * Eigen::Vector3d::UnitY() - Eigen::Vector3d(0, -1, 0)).norm(), 0, 1e-15);
  EXPECT_NEAR(l.cx, -std::tan(-0.9) * l.fx, 1e-9);  // row 0's fov until t = 1
  EXPECT_NEAR(track.At(1.5, Eye::kLeft, 100, 100).cx, -std::tan(-0.8) * track.At(1.5, Eye::kLeft, 100, 100).fx,
              1e-9);
  EXPECT_NEAR(track.At(0.5, Eye::kRight, 100, 100).world_from_eye.translation.x(), 0.532, 1e-12);
  for (const auto& [bad, why] : std::vector<std::pair<std::string, std::string>>{
           {"0,2,0,0,0,0,0,0,1,-0.9,0.7,0.8,-0.8\n", "eye must be 0"},
           {"0,0,0,0,0,0,0,0,0,-0.9,0.7,0.8,-0.8\n", "zero quaternion"},
           {"0,0,0,0,0,0,0,0,1,0.9,0.7,0.8,-0.8\n", "left must be less than right"},
           {"0,0,0,0,0,0,0,0,1,-0.9,0.7,0.8,-0.8\n", "no row of the right eye"}}) {
    std::ofstream(path) << bad;
    try {
      LoadStereoViewTrack(path);
      ADD_FAILURE() << "accepted " << bad;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
}

TEST(StereoOptions, NamesTheFlagOutOfRange) {
  StereoOptions o;
  EXPECT_NO_THROW(o.Check());
  o.ipd_m = 0.2;
  EXPECT_THROW(o.Check(), std::invalid_argument);
  o = {};
  o.right.left = 1.0;
  try {
    o.Check();
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--fov-right"), std::string::npos);
  }
}

}  // namespace
}  // namespace hullpipe
