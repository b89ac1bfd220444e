// The CPU plane sweep (paper §3.3) against exact ground truth: brute-force
// plane-by-plane point queries, the analytic sphere, the exact ray–hull intervals
// (exact_hull.h), refinement, and the hard cases, each with its exact expectation.
#include "hullpipe/util/percentile.h"
#include "hullpipe/reconstruction/plane_sweep.h"

#include "hullpipe/reconstruction/exact_hull.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>
#include <thread>
#include <cmath>
#include <random>

#include <Eigen/Geometry>

#include <gtest/gtest.h>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/evaluation/depth_eval.h"
#include "hullpipe/reconstruction/empty_space.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/texture.h"
#include "hullpipe/testing/fixtures.h"
#include "hullpipe/testing/stop_timing.h"

namespace hullpipe {
namespace {

// The test sphere of the shared fixtures (SphereViews, SphereHull, SphereSideView).
using test::kSphereCentre;
using test::kSphereRadius;

using test::SphereHull;


// Reference sweep: every plane of every pixel tested with the double-precision
// Inside(), front to back. The fast sweep (floats, box clipping, camera
// reordering) must give the same plane except where float rounding moves a plane
// point across a silhouette border: then one plane apart at most.
TEST_F(SphereHull, CpuSweepEqualsBruteForcePlaneByPlane) {
  const NovelView view = test::SphereSideView();
  PlaneSweepOptions o;
  o.num_planes = 60;
  const auto depths = SweepPlaneDepths(query_, view, o);
  ASSERT_EQ(depths.size(), 60u);
  const cv::Rect tile(0, 0, view.width, view.height);
  const cv::Mat fast = PlaneSweepCpu(query_, view, depths, tile);
  int equal = 0, hull = 0, one_apart = 0;
  for (int r = 0; r < view.height; ++r)
    for (int c = 0; c < view.width; ++c) {
      const Eigen::Vector3d D = view.world_from_eye.rotation * view.EyeRay(c + 0.5, r + 0.5);
      float ref = kNoDepth;
      for (double d : depths)
        if (query_.Inside(view.world_from_eye.translation + d * D)) {
          ref = float(d);
          break;
        }
      const float got = fast.at<float>(r, c);
      if (std::isfinite(ref)) ++hull;
      if (got == ref) {
        ++equal;
      } else {
        ++one_apart;
        ASSERT_TRUE(std::isfinite(got) && std::isfinite(ref)) << r << "," << c;
        EXPECT_LE(std::abs(got - ref), (depths[1] - depths[0]) * 1.01);
      }
    }
  EXPECT_GT(hull, 1000);
  EXPECT_LE(one_apart, hull / 200) << "more than 0.5% of hull pixels differ";
}

TEST_F(SphereHull, SweepDepthBoundsTheTrueSphere) {
  // The hull contains the sphere up to pixelisation, so along each ray the first
  // hull point is at or before the sphere, give or take one plane spacing and one
  // camera pixel footprint (3.1 m / 292 px = 1.06 cm) along the ray, i.e. divided
  // by the cosine of incidence on the sphere.
  const NovelView view = test::SphereSideView();
  PlaneSweepOptions o;
  o.num_planes = 200;
  const auto depths = SweepPlaneDepths(query_, view, o);
  const double spacing = depths[1] - depths[0];
  const cv::Mat d = PlaneSweepCpu(query_, view, depths, {0, 0, view.width, view.height}, nullptr, 2);
  const Shape sphere = Shape::Sphere(kSphereCentre, kSphereRadius);
  int hits = 0;
  for (int r = 0; r < view.height; ++r)
    for (int c = 0; c < view.width; ++c) {
      const Eigen::Vector3d D = view.world_from_eye.rotation * view.EyeRay(c + 0.5, r + 0.5);
      const auto s = Shape::Sphere(kSphereCentre, kSphereRadius - 0.03).Intersect(view.world_from_eye.translation, D);
      if (!s) continue;  // only rays well inside the silhouette
      const auto exact = sphere.Intersect(view.world_from_eye.translation, D);
      ++hits;
      ASSERT_TRUE(std::isfinite(d.at<float>(r, c)));
      const Eigen::Vector3d hit = view.world_from_eye.translation + *exact * D;
      const double cos_incidence = std::abs(sphere.Normal(hit).dot(D.normalized()));
      const double footprint = 3.1 / 292.0;
      EXPECT_LE(d.at<float>(r, c), *exact + spacing + footprint / cos_incidence + 1e-6) << r << "," << c;
    }
  EXPECT_GT(hits, 500);
}

TEST_F(SphereHull, TilesAssembleToTheWholeView) {
  // What two (or three) recon nodes render assembles to exactly what one renders,
  // with and without depth refinement (whose silhouette pass looks at neighbours).
  const NovelView view = test::SphereSideView();
  const auto depths = SweepPlaneDepths(query_, view, {});
  for (int refine : {0, 8}) {
    const cv::Mat whole = PlaneSweepCpu(query_, view, depths, {0, 0, view.width, view.height}, nullptr, 1, refine);
    for (int n : {2, 3}) {
      cv::Mat assembled(view.height, view.width, CV_32FC1);
      for (int i = 0; i < n; ++i) {
        const cv::Rect t = TileRect(i, n, view.width, view.height);
        PlaneSweepCpu(query_, view, depths, t, nullptr, 1, refine).copyTo(assembled(t));
      }
      // Exactly equal, infinities included (memcmp-like).
      EXPECT_EQ(std::memcmp(whole.data, assembled.data, whole.total() * whole.elemSize()), 0)
          << n << " tiles, refine " << refine;
    }
  }
  EXPECT_THROW(TileRect(2, 2, 10, 10), std::invalid_argument);
}

TEST(PlaneSweep, NoNanOrInfiniteDepthOtherThanNoHull) {
  const VolumeQuery q(test::SphereViews(4, 160, 120, kSphereCentre, kSphereRadius), test::BigBox());
  // A view from inside the hull box, looking through the sphere's centre.
  const Rigid3d pose =
      LookAt(kSphereCentre + Eigen::Vector3d(0.05, 0, 0), kSphereCentre + Eigen::Vector3d(1, 0, 0), {0, 0, -1});
  const NovelView view = NovelView::FromFov(80, 60, 1.5, pose);
  const cv::Mat d = PlaneSweepCpu(q, view, SweepPlaneDepths(q, view, {}), {0, 0, 80, 60});
  for (auto it = d.begin<float>(); it != d.end<float>(); ++it) EXPECT_TRUE(!std::isnan(*it) && *it > 0);
}






// Membership from the exact intervals equals VolumeQuery::Inside at every sample,
// except within 1e-9 m of an interval boundary (where the double-precision
// projection of the sample and of the crossing may round differently).

// The sweep's plane for each pixel is exactly the first plane depth that lies in
// the pixel ray's exact hull intervals (or none). Float projection in the sweep
// may flip a plane point within 1e-5 m of an interval boundary; such pixels are
// counted, not failed, and must be rare.
void ExpectSweepMatchesExact(const VolumeQuery& q, const NovelView& view, const std::vector<double>& depths,
                             const cv::Mat& sweep, int* hull_pixels = nullptr) {
  ASSERT_EQ(sweep.rows, view.height);
  int near_boundary = 0, hull = 0;
  const Eigen::Vector3d O = view.world_from_eye.translation;
  for (int r = 0; r < view.height; ++r)
    for (int c = 0; c < view.width; ++c) {
      const float got = sweep.at<float>(r, c);
      ASSERT_FALSE(std::isnan(got));
      ASSERT_TRUE(got > 0) << "depth is positive or +inf (no hull)";
      const Eigen::Vector3d D = view.world_from_eye.rotation * view.EyeRay(c + 0.5, r + 0.5);
      double s0 = 1e-9, s1 = 1e9;
      Intervals iv;
      if (q.hull_box().ClipRay(O, D, &s0, &s1)) iv = RayHullIntervals(q, O, D, s0, s1);
      float want = kNoDepth;
      for (double d : depths)
        if (d >= s0 && d <= s1 && test::InIntervals(iv, d)) {
          want = float(d);
          break;
        }
      hull += std::isfinite(want);
      if (got == want) continue;
      // Allowed only if a plane between the two is within 1e-5 m of a boundary.
      bool explained = false;
      for (double d : depths)
        if (d <= std::max(double(got), double(want)) + 1e-9 && test::DistanceToBoundary(iv, d) * D.norm() < 1e-5)
          explained = true;
      ASSERT_TRUE(explained) << "pixel " << c << "," << r << " sweep " << got << " exact " << want;
      ++near_boundary;
    }
  EXPECT_LE(near_boundary, std::max(2, hull / 100));
  if (hull_pixels) *hull_pixels = hull;
}

// Sweeps `view` with `planes` planes (fitted to the hull box) and checks it against
// the exact reference; returns the number of exact hull pixels.
int SweepMatchesExact(const VolumeQuery& q, const NovelView& view, int planes) {
  PlaneSweepOptions so;
  so.num_planes = planes;
  const auto depths = SweepPlaneDepths(q, view, so);
  int hull = 0;
  ExpectSweepMatchesExact(q, view, depths, PlaneSweepCpu(q, view, depths, {0, 0, view.width, view.height}), &hull);
  return hull;
}

// The sphere of these tests, and exact maps of a scene for some cameras.
SyntheticScene OneSphere() {
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Sphere(kSphereCentre, kSphereRadius));
  return scene;
}

TEST(ExactHull, SweepEqualsExactPlaneMembership) {
  for (const OutOfView p : {OutOfView::kOutside, OutOfView::kUnknown}) {
    VolumeQueryOptions o;
    o.out_of_view = p;
    const VolumeQuery q(test::SphereViews(4, 160, 120, kSphereCentre, kSphereRadius), test::BigBox(), o);
    const NovelView view = test::SphereSideView();
    PlaneSweepOptions so;
    so.num_planes = 40;
    const auto depths = SweepPlaneDepths(q, view, so);
    int hull = 0;
    ExpectSweepMatchesExact(q, view, depths, PlaneSweepCpu(q, view, depths, {0, 0, 160, 120}), &hull);
    EXPECT_GT(hull, 1000);
  }
}

TEST(ExactHull, RefinementRemovesThePlaneSpacingFromTheError) {
  // 16 planes over ~0.7 m: 4.5 cm apart. 12 bisections: 11 µm. Where the first
  // inside plane lies in the first exact interval and the interval before it
  // starts after the previous plane, bisection converges to the exact entry.
  const VolumeQuery q(test::SphereViews(4, 160, 120, kSphereCentre, kSphereRadius), test::BigBox());
  const NovelView view = test::SphereSideView();
  PlaneSweepOptions so;
  so.num_planes = 16;
  const auto depths = SweepPlaneDepths(q, view, so);
  const cv::Rect all(0, 0, view.width, view.height);
  const cv::Mat exact = ExactHullDepth(q, view, all);
  const cv::Mat coarse = PlaneSweepCpu(q, view, depths, all, nullptr, 1, 0);
  const cv::Mat refined = PlaneSweepCpu(q, view, depths, all, nullptr, 2, 12);
  std::vector<double> err_coarse, err_refined;
  for (int r = 0; r < view.height; ++r)
    for (int c = 0; c < view.width; ++c) {
      const float e = exact.at<float>(r, c), a = coarse.at<float>(r, c), b = refined.at<float>(r, c);
      if (std::isfinite(a)) {
        ASSERT_TRUE(std::isfinite(b)) << "refinement never removes hull";
      }
      // It may add hull the planes missed (a thin piece at a silhouette); then
      // the exact hull is there too.
      if (std::isfinite(b)) {
        ASSERT_TRUE(std::isfinite(e)) << r << "," << c;
      }
      if (!std::isfinite(e) || !std::isfinite(b) || !std::isfinite(a)) continue;
      EXPECT_GE(b, e - 1e-4) << "never in front of the exact entry (float slack)";
      err_coarse.push_back(std::abs(a - e));
      err_refined.push_back(std::abs(b - e));
    }
  ASSERT_GT(err_refined.size(), 1000u);
  EXPECT_GT(Median(err_coarse), 5e-3);
  EXPECT_LT(Median(err_refined), 1e-4);  // 0.1 mm: the bisection's 11 µm plus float rounding
}

// ---- Hard cases -----------------------------------------------------------

TEST(HardCase, PointBehindACameraIsOutsideNeverMirrored) {
  // One camera, full map except nothing: the mirror image of a point behind the
  // camera projects to (u, v) in the image; it must not count as object.
  Camera cam = RingCameras(1, 2.0, 1.0, kSphereCentre, 100, 80, 1.0)[0];
  cv::Mat map(80, 100, CV_8UC1, cv::Scalar(255));
  const Eigen::Vector3d front = kSphereCentre, behind = cam.Center() - (kSphereCentre - cam.Center());
  for (const OutOfView p : {OutOfView::kOutside, OutOfView::kUnknown}) {
    VolumeQueryOptions o;
    o.out_of_view = p;
    o.min_seen = 1;
    const VolumeQuery q({{cam, map}}, test::BigBox(), o);
    EXPECT_TRUE(q.Inside(front));
    EXPECT_EQ(q.VoteOf(0, behind), Vote::kUnseen);
    EXPECT_FALSE(q.Inside(behind)) << "unseen by its only camera: fewer than min_seen see it";
    EXPECT_EQ(q.Count(behind), 0);
    // Along the line through both, the exact hull stops at the camera centre.
    const Intervals iv = RayHullIntervals(q, behind, front - behind, 0.0, 1.0);
    ASSERT_EQ(iv.size(), 1u);
    EXPECT_NEAR(iv[0].first, 0.5, 1e-6);
  }
}

TEST(HardCase, PlanesThroughACameraCentreAndParallelToItsImagePlane) {
  // The novel view sits at camera 0's centre looking along its axis: every sweep
  // plane is parallel to camera 0's image plane. A second view is placed so that
  // one of its planes passes through camera 1's centre (the plane projects to a
  // line in camera 1).
  const VolumeQuery q(test::SphereViews(4, 160, 120, kSphereCentre, kSphereRadius), test::BigBox());
  const Camera& c0 = q.views()[0].camera;
  NovelView along = test::SphereSideView();
  along.world_from_eye = c0.cam_from_world.Inverse();
  PlaneSweepOptions so;
  so.num_planes = 30;
  auto depths = SweepPlaneDepths(q, along, so);
  ExpectSweepMatchesExact(q, along, depths, PlaneSweepCpu(q, along, depths, {0, 0, 160, 120}));

  const NovelView side = test::SphereSideView();
  const Eigen::Vector3d c1_eye = side.world_from_eye.Inverse() * q.views()[1].camera.Center();
  std::vector<double> through = {c1_eye.z()};  // a plane through camera 1's centre...
  for (double d : SweepPlaneDepths(q, side, so)) through.push_back(d);  // ...and the usual ones
  std::sort(through.begin(), through.end());
  through.erase(std::remove_if(through.begin(), through.end(), [](double d) { return d <= 0; }), through.end());
  ExpectSweepMatchesExact(q, side, through, PlaneSweepCpu(q, side, through, {0, 0, 160, 120}));
}

TEST(HardCase, CameraAtAGrazingAngleToTheSweepPlanes) {
  // Camera 1 looks along the sweep planes (its axis is perpendicular to the
  // view's): each plane projects to a thin band of its image.
  const VolumeQuery q(test::SphereViews(4, 160, 120, kSphereCentre, kSphereRadius), test::BigBox());
  const Camera& c1 = q.views()[1].camera;
  NovelView view = test::SphereSideView();
  // Eye axis perpendicular to camera 1's axis, looking at the sphere.
  const Eigen::Vector3d axis1 = c1.cam_from_world.rotation.row(2).transpose();
  const Eigen::Vector3d up(0, 0, -1);
  const Eigen::Vector3d dir = axis1.cross(up).normalized();
  view.world_from_eye = LookAt(kSphereCentre - 2.5 * dir, kSphereCentre, up);
  EXPECT_GT(SweepMatchesExact(q, view, 50), 300);
}

TEST(HardCase, ShapePartlyOutsideACameraImage) {
  // Camera 0 is narrow and aimed to the side: the sphere's far half is outside
  // its image. kOutside clips the hull there (the paper); kUnknown lets the other
  // cameras decide.
  const SyntheticScene scene = OneSphere();
  auto cams = RingCameras(4, 3.0, 1.8, kSphereCentre, 160, 120, 1.0);
  // Re-aim camera 0 so the sphere centre projects at its right border's column.
  Camera& c0 = cams[0];
  const Eigen::Vector3d C = c0.Center();
  // Half the field of view is 0.5 rad; turn 0.55 rad away so the centre is 0.05
  // rad (~15 cm at 3 m) beyond the border and the sphere (r 0.3) straddles it.
  const double dist = (kSphereCentre - C).norm();
  const Eigen::Vector3d aim =
      kSphereCentre + (kSphereCentre - C).cross(Eigen::Vector3d(0, 0, -1)).normalized() * dist * std::tan(0.55);
  c0.cam_from_world = LookAt(C, aim, Eigen::Vector3d(0, 0, -1)).Inverse();
  const std::vector<CameraMap> views = test::ExactViews(cams, scene);
  VolumeQueryOptions outside, unknown;
  outside.out_of_view = OutOfView::kOutside;
  const VolumeQuery qo(views, test::BigBox(), outside), qu(views, test::BigBox(), unknown);
  // The sphere's centre projects outside camera 0's image.
  ASSERT_EQ(qo.VoteOf(0, kSphereCentre), Vote::kUnseen);
  EXPECT_FALSE(qo.Inside(kSphereCentre)) << "kOutside: clipped by the camera that cannot see it";
  EXPECT_TRUE(qu.Inside(kSphereCentre)) << "kUnknown: the other three cameras see it inside";
  // A point outside the sphere that camera 0 would have rejected is still outside.
  EXPECT_FALSE(qu.Inside(kSphereCentre + Eigen::Vector3d(0, 0, -0.5)));
  // The hull boxes stay conservative: every sphere point inside the hull is in them.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d p = kSphereCentre + Eigen::Vector3d(u(rng), u(rng), u(rng)) * kSphereRadius;
    if (qu.Inside(p)) { ASSERT_TRUE(qu.hull_box().Contains(p)); }
    if (qo.Inside(p)) { ASSERT_TRUE(qo.hull_box().Contains(p)); }
  }
  // The sweep matches the exact reference under both policies.
  const NovelView view = test::SphereSideView();
  for (const VolumeQuery* q : {&qo, &qu}) {
    const auto depths = SweepPlaneDepths(*q, view, {});
    ExpectSweepMatchesExact(*q, view, depths, PlaneSweepCpu(*q, view, depths, {0, 0, 160, 120}));
  }
}

TEST(HardCase, EmptyMapGivesAnEmptyHull) {
  auto views = test::SphereViews(4, 160, 120, kSphereCentre, kSphereRadius);
  views[2].map.setTo(0);
  Aabb seen_by_all;  // a workspace every camera sees whole: the empty map always votes
  seen_by_all.min = kSphereCentre - Eigen::Vector3d::Constant(0.5);
  seen_by_all.max = kSphereCentre + Eigen::Vector3d::Constant(0.5);
  for (const OutOfView p : {OutOfView::kOutside, OutOfView::kUnknown}) {
    VolumeQueryOptions o;
    o.out_of_view = p;
    const VolumeQuery q(views, seen_by_all, o);
    EXPECT_TRUE(q.hull_box().empty());
    EXPECT_FALSE(q.Inside(kSphereCentre));
    const NovelView view = test::SphereSideView();
    const cv::Mat d = PlaneSweepCpu(q, view, SweepPlaneDepths(q, view, {}), {0, 0, 160, 120});
    EXPECT_EQ(cv::countNonZero(d != kNoDepth), 0);
    EXPECT_TRUE(RayHullIntervals(q, kSphereCentre - Eigen::Vector3d(2, 0, 0), {1, 0, 0}, 0, 4).empty());
  }
}

TEST(HardCase, FullMapDoesNotConstrain) {
  // A camera whose map is all object adds nothing where it sees: the hull is that
  // of the other three inside its view.
  auto views = test::SphereViews(4, 160, 120, kSphereCentre, kSphereRadius);
  auto three = views;
  three.erase(three.begin() + 1);
  views[1].map.setTo(255);
  Aabb ws;
  ws.min = kSphereCentre - Eigen::Vector3d::Constant(0.5);
  ws.max = kSphereCentre + Eigen::Vector3d::Constant(0.5);
  const VolumeQuery q4(views, ws), q3(three, ws);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 5000; ++i) {
    const Eigen::Vector3d p = kSphereCentre + Eigen::Vector3d(u(rng), u(rng), u(rng)) * 0.5;
    ASSERT_EQ(q4.Inside(p), q3.Inside(p)) << p.transpose();
  }
}

TEST(HardCase, ObjectOnePixelWide) {
  // Camera 0's map has one object pixel; the others are full. The hull is the
  // thin pyramid through that pixel: the ray through its centre is inside from the
  // camera to the workspace's edge, its neighbours' rays are not.
  const auto cams = RingCameras(3, 2.0, 1.0, kSphereCentre, 100, 80, 1.0);
  std::vector<CameraMap> views;
  for (const auto& c : cams) views.push_back({c, cv::Mat(80, 100, CV_8UC1, cv::Scalar(255))});
  views[0].map.setTo(0);
  views[0].map.at<uint8_t>(40, 50) = 255;
  Aabb ws;
  ws.min = kSphereCentre - Eigen::Vector3d::Constant(0.4);
  ws.max = kSphereCentre + Eigen::Vector3d::Constant(0.4);
  const VolumeQuery q(views, ws);
  const Camera& c0 = cams[0];
  const Eigen::Vector3d O = c0.Center();
  const Intervals hit = RayHullIntervals(q, O, c0.PixelRayWorld({50.5, 40.5}), 0, 10);
  ASSERT_EQ(hit.size(), 1u);
  double s0 = 0, s1 = 10;
  ASSERT_TRUE(ws.ClipRay(O, c0.PixelRayWorld({50.5, 40.5}), &s0, &s1));
  EXPECT_NEAR(hit[0].first, s0, 1e-9);
  EXPECT_NEAR(hit[0].second, s1, 1e-9);
  EXPECT_TRUE(RayHullIntervals(q, O, c0.PixelRayWorld({51.5, 40.5}), 0, 10).empty());
  EXPECT_TRUE(RayHullIntervals(q, O, c0.PixelRayWorld({50.5, 39.5}), 0, 10).empty());
  // The sweep from a view beside camera 0 finds the sliver as the exact reference does.
  NovelView view = test::SphereSideView(200, 150);
  view.world_from_eye = LookAt(cams[1].Center(), kSphereCentre, {0, 0, -1});
  EXPECT_GT(SweepMatchesExact(q, view, 400), 0);
}

TEST(HardCase, CamerasOfDifferentResolutions) {
  const SyntheticScene scene = OneSphere();
  const int sizes[4][2] = {{64, 48}, {160, 120}, {320, 240}, {101, 77}};
  std::vector<CameraMap> views;
  auto cams = RingCameras(4, 3.0, 1.8, kSphereCentre, 160, 120, 1.0);
  for (size_t i = 0; i < 4; ++i) {
    Camera c = cams[i];
    const double s = double(sizes[i][0]) / 160.0;
    c.width = sizes[i][0], c.height = sizes[i][1];
    c.fx *= s, c.fy *= s, c.cx = c.width / 2.0, c.cy = c.height / 2.0;
    views.push_back({c, RenderExactMap(c, scene)});
  }
  EXPECT_GT(SweepMatchesExact(VolumeQuery(views, test::BigBox()), test::SphereSideView(), 50), 1000);
}

TEST(HardCase, NearlyParallelCameras) {
  // Two cameras 1 mm apart looking the same way: their pyramids barely cross, so
  // the hull is long along the axis (ill-conditioned depth). The sweep and the
  // exact reference still agree, with no NaN.
  const SyntheticScene scene = OneSphere();
  const Eigen::Vector3d C = kSphereCentre + Eigen::Vector3d(0, -3, 0);
  std::vector<CameraMap> views;
  for (double dx : {0.0, 0.001}) {
    Camera c = RingCameras(1, 3.0, 1.8, kSphereCentre, 160, 120, 1.0)[0];
    c.cam_from_world = LookAt(C + Eigen::Vector3d(dx, 0, 0), kSphereCentre, {0, 0, -1}).Inverse();
    views.push_back({c, RenderExactMap(c, scene)});
  }
  Aabb ws;
  ws.min = kSphereCentre - Eigen::Vector3d::Constant(1.0);
  ws.max = kSphereCentre + Eigen::Vector3d::Constant(1.0);
  EXPECT_GT(SweepMatchesExact(VolumeQuery(views, ws), test::SphereSideView(), 50), 1000);
}

TEST(HardCase, NearAndFarPlanesCutTheShape) {
  // Near and far inside the sphere: pixels whose ray is inside at the near plane
  // get depth == near exactly; nothing lies beyond far.
  const VolumeQuery q(test::SphereViews(4, 160, 120, kSphereCentre, kSphereRadius), test::BigBox());
  const NovelView view = test::SphereSideView();
  const double dist = (view.world_from_eye.translation - kSphereCentre).norm();
  PlaneSweepOptions so;
  so.fit_planes_to_hull_box = false;
  so.near = dist - 0.1;
  so.far = dist + 0.1;
  so.num_planes = 21;
  const auto depths = SweepPlaneDepths(q, view, so);
  ASSERT_FALSE(depths.empty());
  EXPECT_NEAR(depths.front(), so.near, 1e-12);
  EXPECT_NEAR(depths.back(), so.far, 1e-12);
  const cv::Mat d = PlaneSweepCpu(q, view, depths, {0, 0, 160, 120}, nullptr, 1, 10);
  ExpectSweepMatchesExact(q, view, depths, PlaneSweepCpu(q, view, depths, {0, 0, 160, 120}));
  EXPECT_FLOAT_EQ(d.at<float>(60, 80), float(so.near)) << "the centre pixel is inside at the near plane";
  double max_depth = 0;
  for (int r = 0; r < 120; ++r)
    for (int c = 0; c < 160; ++c)
      if (std::isfinite(d.at<float>(r, c))) max_depth = std::max(max_depth, double(d.at<float>(r, c)));
  EXPECT_LE(max_depth, so.far + 1e-6);
}

TEST(PlaneSweep, RefiningAfterwardsEqualsRefiningInTheSweep) {
  // The GL backend refines a finished sweep with RefineSweepDepth; it must agree
  // with the CPU sweep's own refinement.
  const VolumeQuery q(test::SphereViews(4, 160, 120, kSphereCentre, kSphereRadius), test::BigBox());
  const NovelView view = test::SphereSideView();
  PlaneSweepOptions so;
  so.num_planes = 24;
  const auto depths = SweepPlaneDepths(q, view, so);
  const cv::Rect all(0, 0, view.width, view.height);
  cv::Mat later = PlaneSweepCpu(q, view, depths, all);
  RefineSweepDepth(q, view, depths, all, 10, &later, 2);
  const cv::Mat inside = PlaneSweepCpu(q, view, depths, all, nullptr, 1, 10);
  // The sweep's own refinement also scans around near misses (stencil count
  // n - 1), which a finished depth image no longer shows: a near miss at plane k
  // is scanned from plane k - 1, so a few pixels may find hull up to two planes in
  // front of the first inside plane; the rest differ by at most two bisection steps.
  const double spacing = depths[1] - depths[0], step = spacing / 1024;
  int finite = 0, close = 0;
  for (int r = 0; r < view.height; ++r)
    for (int c = 0; c < view.width; ++c) {
      const float a = later.at<float>(r, c), b = inside.at<float>(r, c);
      if (!std::isfinite(a) || !std::isfinite(b)) continue;
      ++finite;
      ASSERT_LE(std::abs(a - b), spacing * 2.01) << r << "," << c;
      close += std::abs(a - b) <= 2 * step + 1e-6;
    }
  EXPECT_GT(finite, 1000);
  EXPECT_GE(close, finite * 97 / 100);  // 97.95% on this scene
  cv::Mat wrong(3, 3, CV_32FC1);
  EXPECT_THROW(RefineSweepDepth(q, view, depths, all, 4, &wrong), std::invalid_argument);
}

}  // namespace
}  // namespace hullpipe

namespace hullpipe {
namespace {

// A node stops within a second of SIGINT mid-sweep (README, "Engineering
// rules"): the sweep polls its stop flag per pixel. An 8192x8192 view with 4096
// planes, the largest recon_node accepts, takes over 10 s here (measured with
// the flag set at 10 s: still interrupted, on 1 and 2 threads);
// the flag is set 0.1 s in, and the sweep must end with Interrupted within
// 0.5 s of it (a pixel's work is at most 4096 planes x n projections,
// microseconds; the margin is for a loaded machine). ThreadSanitizer's run
// stretches the bound by test::TimeScale(): there, unwinding and freeing the
// 8192x8192 output alone took 0.6 s.
// Interrupted, not a depth map, also shows the sweep was still running when
// the flag was set.
TEST_F(SphereHull, AStopFlagEndsTheLargestSweepWithinHalfASecond) {
  const NovelView view = test::SphereSideView(8192, 8192);
  PlaneSweepOptions o;
  o.num_planes = PlaneSweepOptions::kMaxPlanes;
  const auto depths = SweepPlaneDepths(query_, view, o);
  ASSERT_EQ(depths.size(), size_t(o.num_planes));
  for (const int threads : {1, 2}) {
    const auto t = test::StopAfter(std::chrono::milliseconds(100), [&](StopFlag stop) {
      PlaneSweepCpu(query_, view, depths, {0, 0, view.width, view.height}, nullptr, threads, 0, stop);
    });
    ASSERT_TRUE(t.seconds) << "the sweep finished before the flag was set; it proves nothing";
    EXPECT_LT(*t.seconds, 0.5 * test::TimeScale()) << threads << " thread(s)";
    EXPECT_NE(t.what.find("plane sweep"), std::string::npos) << t.what;
  }
}

// Every long call of a render honours a flag already set, and an unset flag
// changes nothing (the control: the same depth, bit for bit, as no flag).
TEST_F(SphereHull, EveryRenderStageHonoursTheStopFlag) {
  const NovelView view = test::SphereSideView();
  const auto depths = SweepPlaneDepths(query_, view, {});
  const cv::Rect whole(0, 0, view.width, view.height);
  std::atomic<bool> stop{false};
  for (const int refine : {0, 6}) {
    const cv::Mat plain = PlaneSweepCpu(query_, view, depths, whole, nullptr, 2, refine);
    const cv::Mat polled = PlaneSweepCpu(query_, view, depths, whole, nullptr, 2, refine, &stop);
    EXPECT_EQ(std::memcmp(plain.data, polled.data, plain.total() * plain.elemSize()), 0) << refine;
  }
  const cv::Mat depth = PlaneSweepCpu(query_, view, depths, whole);
  std::vector<CameraImage> images;
  std::vector<Camera> cameras;
  for (const auto& v : test::SphereViews(4, 320, 240, kSphereCentre, kSphereRadius)) {
    images.push_back({v.camera, cv::Mat(v.camera.height, v.camera.width, CV_8UC3, cv::Scalar(10, 20, 30))});
    cameras.push_back(v.camera);
  }
  EXPECT_NO_THROW(TextureHull(depth, whole, view, images, {}, nullptr, &stop));
  stop = true;
  EXPECT_THROW(PlaneSweepCpu(query_, view, depths, whole, nullptr, 1, 0, &stop), Interrupted);
  EXPECT_THROW(PlaneSweepCpu(query_, view, depths, whole, nullptr, 2, 6, &stop), Interrupted);
  cv::Mat refined = depth.clone();
  EXPECT_THROW(RefineSweepDepth(query_, view, depths, whole, 6, &refined, 1, &stop), Interrupted);
  EXPECT_THROW(ComputeHullVisibility(query_, cameras, 64, {}, 0, 1, &stop), Interrupted);
  EXPECT_THROW(TextureHull(depth, whole, view, images, {}, nullptr, &stop), Interrupted);
}

// --planes 100000 once stalled recon_node past SIGINT: bounded, named.
TEST(PlaneSweepOptions, PlanesAreBounded) {
  PlaneSweepOptions o;
  o.num_planes = 100000;
  EXPECT_THROW(o.Check(), std::invalid_argument);
  o.num_planes = 1;
  EXPECT_THROW(o.Check(), std::invalid_argument);
  o.num_planes = PlaneSweepOptions::kMaxPlanes;
  EXPECT_NO_THROW(o.Check());  // control
}

}  // namespace
}  // namespace hullpipe

namespace hullpipe {
namespace {

// A hard scene for the sweep's shortcuts: a sphere, a capsule thinner than the
// plane spacing and a torus.
SyntheticScene ThinPartsScene() {
  const Eigen::Vector3d centre = kSphereCentre;
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Sphere(centre, 0.22));
  scene.shapes.push_back(Shape::Capsule(centre + Eigen::Vector3d(-0.4, 0.3, 0.1),
                                        centre + Eigen::Vector3d(0.4, 0.35, -0.2), 0.012));
  scene.shapes.push_back(Shape::Torus(centre + Eigen::Vector3d(0.0, -0.35, 0.0), 0.15, 0.04));
  return scene;
}

// A ring of ncam 240x180 cameras around it: lens 0 pinhole, 1 mildly
// distorted (k1 = -0.12), 2 the Utrecht rig's cam1 lens; with that skew.
std::vector<CameraMap> ThinPartsViews(int ncam, int lens, double skew) {
  Distortion d{};
  if (lens == 1) d[0] = -0.12;
  if (lens == 2) d = test::kUtrechtCam1Lens;
  return test::ExactViews(test::WithSkew(RingCameras(ncam, 3.0, 1.8, kSphereCentre, 240, 180, 1.0, d), skew),
                          ThinPartsScene());
}

// Three views of it (200x150 unless sized), from three sides.
std::vector<NovelView> ThinPartsEyes(int width = 200, int height = 150) {
  std::vector<NovelView> eyes;
  for (const Eigen::Vector3d& from : {Eigen::Vector3d(2.0, 1.2, -0.5), Eigen::Vector3d(-1.5, 2.0, -1.0),
                                      Eigen::Vector3d(0.3, -2.2, -0.2)})
    eyes.push_back(
        NovelView::FromFov(width, height, 0.8, LookAt(kSphereCentre + from, kSphereCentre, {0, 0, -1})));
  return eyes;
}

// The refinement's near-miss scans a camera vetoes whole are skipped
// (VolumeQueryOptions::prune_near_misses): on the thin parts scene from rings
// of 4 and 5 cameras, skewed and not, pinhole, mildly distorted and with the
// Utrecht rig's lenses (whose projections of a scan's bracket are curved:
// LensBulgePx), and views from three sides, the depth images with and without
// are the same to the bit. Positive control: scans were skipped (most of the
// near misses) under every lens.
TEST(NearMissPruning, SkippedScansChangeNoPixel) {
  for (const int ncam : {4, 5}) {
    for (const double skew : {0.0, 0.06}) {
      for (const int lens : {0, 1, 2}) {
        const std::vector<CameraMap> views = ThinPartsViews(ncam, lens, skew);
        VolumeQueryOptions on, off;
        off.prune_near_misses = false;
        const VolumeQuery qa(views, test::BigBox(), on), qb(views, test::BigBox(), off);
        int64_t pruned = 0, scanned_before = 0;
        for (const NovelView& view : ThinPartsEyes()) {
          for (const int planes : {30, 100}) {
            PlaneSweepOptions o;
            o.num_planes = planes;
            const auto depths = SweepPlaneDepths(qa, view, o);
            SweepStats sa, sb;
            const cv::Mat a = PlaneSweepCpu(qa, view, depths, {0, 0, 200, 150}, &sa, 1, 6);
            const cv::Mat b = PlaneSweepCpu(qb, view, depths, {0, 0, 200, 150}, &sb, 1, 6);
            const std::string what = std::to_string(ncam) + " cameras, skew " + std::to_string(skew) + ", lens " +
                                     std::to_string(lens) + ", " + std::to_string(planes) + " planes";
            EXPECT_EQ(cv::countNonZero(a != b), 0) << what;
            EXPECT_EQ(sb.pruned, 0) << what;
            EXPECT_LE(sa.projections, sb.projections) << what;
            pruned += sa.pruned;
            scanned_before += sb.projections - sa.projections;
          }
        }
        EXPECT_GT(pruned, 1000) << ncam << " cameras, skew " << skew << ", lens " << lens;
        EXPECT_GT(scanned_before, 10 * pruned) << "each skipped scan saves its points' projections";
      }
    }
  }
}

// Sweeps `views` through queries a and b (a shortcut on and off) from the thin
// parts eyes (width x height), at 30, 100 and 300 planes, without and with
// refinement; expects the same depth images and hands each pair's stats and
// description to `check`.
template <class Check>
void CompareThinPartsSweeps(const VolumeQuery& qa, const VolumeQuery& qb, int width, int height, Check check) {
  for (const NovelView& view : ThinPartsEyes(width, height)) {
    for (const int planes : {30, 100, 300}) {
      for (const int refine : {0, 6}) {
        PlaneSweepOptions o;
        o.num_planes = planes;
        const auto depths = SweepPlaneDepths(qa, view, o);
        SweepStats sa, sb;
        const cv::Mat a = PlaneSweepCpu(qa, view, depths, {0, 0, width, height}, &sa, 1, refine);
        const cv::Mat b = PlaneSweepCpu(qb, view, depths, {0, 0, width, height}, &sb, 1, refine);
        const std::string what = std::to_string(qa.size()) + " cameras, " + std::to_string(planes) +
                                 " planes, refine " + std::to_string(refine);
        EXPECT_EQ(cv::countNonZero(a != b), 0) << what;
        check(sa, sb, what);
      }
    }
  }
}

// The empty-space grid's hit bounds (EmptySpace::DepthBounds: where a cube no
// camera vetoes lies) end each ray's march and skip its points in front, whose
// near misses are counted only when which are the first kept depends on them:
// on the thin parts scene, rings of 4 and 5 cameras under three lenses, three
// views, 30 to 300 planes, with and without refinement, the depth images with
// the grid and without it (no bounds, every point asked) are the same to the
// bit. The views are 320x240: the grid bounds a view of at least
// EmptySpace::kPixelsPerOpenCube pixels per open cube (~10,000 cubes here).
// Positive control: points in the bounds were skipped as no hit.
TEST(HitBounds, PointsWhereNoHitCanBeAreSkippedChangingNoPixel) {
  for (const int ncam : {4, 5}) {
    for (const int lens : {0, 1, 2}) {
      const std::vector<CameraMap> views = ThinPartsViews(ncam, lens, 0.06 * lens);
      VolumeQueryOptions off;
      off.empty_space_cells = 0;
      const VolumeQuery qa(views, test::BigBox()), qb(views, test::BigBox(), off);
      int64_t skipped = 0, visited = 0;
      SCOPED_TRACE("lens " + std::to_string(lens));
      CompareThinPartsSweeps(qa, qb, 320, 240, [&](const SweepStats& sa, const SweepStats& sb, const std::string& w) {
        EXPECT_EQ(sb.hit_skipped, 0) << w;
        skipped += sa.hit_skipped;
        visited += sa.plane_points;
      });
      EXPECT_GT(skipped, visited / 10) << ncam << " cameras, lens " << lens;
    }
  }
}

// The sweep's bounds (SweepDepthBounds) against the cameras' own votes: on
// the thin parts scene from 4 cameras under three lenses, three 320x240
// views and 100 planes, every sample of a ray (4 mm apart, in doubles)
// outside its block's hit bounds is on background in some camera, and every
// one before its near bound in two. Positive controls: the pieces of the
// frustum cut a third more of the samples than the grid's cubes alone, from
// the hit bounds and from the near bound, and the bounds still hold every
// exact hull depth the sweep finds.
TEST(SweepBounds, NarrowedByTheFrustumsPiecesAndStillBounds) {
  for (const int lens : {0, 1, 2}) {
    const VolumeQuery q(ThinPartsViews(4, lens, 0.06 * lens), test::BigBox());
    int64_t all = 0, outside_hit = 0, outside_hit_grid = 0, before_near = 0, before_near_grid = 0;
    for (const NovelView& view : ThinPartsEyes(320, 240)) {
      PlaneSweepOptions o;
      o.num_planes = 100;
      const auto depths = SweepPlaneDepths(q, view, o);
      const cv::Rect region(0, 0, 320, 240);
      SweepBounds b, grid;
      ASSERT_TRUE(SweepDepthBounds(q, view, region, depths, true, &b));
      ASSERT_TRUE(q.empty_space().DepthBounds(view, region, &grid.near, &grid.far, nullptr, &grid.hit_near,
                                              &grid.hit_far));
      const cv::Mat swept = PlaneSweepCpu(q, view, depths, region, nullptr, 1, 6);
      constexpr int B = EmptySpace::kBoundsBlock;
      const Eigen::Vector3d O = view.world_from_eye.translation;
      for (int r = 0; r < region.height; r += 3)
        for (int c = 0; c < region.width; c += 3) {
          const int i = r / B, j = c / B;
          const float lo = b.near.at<float>(i, j), lo_grid = grid.near.at<float>(i, j);
          const float hit0 = b.hit_near.at<float>(i, j), hit1 = b.hit_far.at<float>(i, j);
          const float grid0 = grid.hit_near.at<float>(i, j), grid1 = grid.hit_far.at<float>(i, j);
          const float z = swept.at<float>(r, c);
          if (std::isfinite(z)) {
            ASSERT_TRUE(z >= hit0 && z <= hit1) << "pixel " << c << "," << r;
          }
          const Eigen::Vector3d D = view.world_from_eye.rotation * view.EyeRay(c + 0.5, r + 0.5);
          double s0 = depths.front(), s1 = depths.back();
          if (!q.hull_box().ClipRay(O, D, &s0, &s1)) continue;
          for (double s = s0; s <= s1; s += 0.004) {
            ++all;
            int background = 0;
            for (size_t k = 0; k < q.size(); ++k) background += q.VoteOf(k, O + s * D) == Vote::kBackground;
            if (!(s >= hit0 && s <= hit1)) {
              ++outside_hit;
              outside_hit_grid += !(s >= grid0 && s <= grid1);
              ASSERT_GE(background, 1) << "lens " << lens << ", pixel " << c << "," << r << ", depth " << s;
            }
            if (s < lo) {
              ++before_near;
              before_near_grid += s < lo_grid;
              ASSERT_GE(background, 2) << "lens " << lens << ", pixel " << c << "," << r << ", depth " << s;
            }
          }
        }
    }
    SCOPED_TRACE("lens " + std::to_string(lens));
    EXPECT_GT(double(outside_hit - outside_hit_grid), 0.3 * double(outside_hit_grid));
    EXPECT_GT(before_near, before_near_grid);
    EXPECT_GT(all, 100000);
  }
}

// The threaded stages hand out rows (or rows of blocks) as workers finish
// (ForEachRowChunk, ForEachRowDynamic), so which thread sweeps a ray, and
// the camera order it inherits, varies from run to run: on the thin parts
// scene from 4 cameras with the Utrecht rig's lenses, three 320x240 views
// (grid and frustum bounds on), 100 planes, without and with refinement, the
// bounds, the depth images, the rays counted and the textured colours (with
// the visibility maps) on 2 and 3 threads are those of 1, to the bit.
// Positive control: every view has hull and open blocks to hand out.
TEST(PlaneSweep, ThreadsChangeNoBoundDepthOrColour) {
  const std::vector<CameraMap> views = ThinPartsViews(4, 2, 0.12);
  const VolumeQuery q(views, test::BigBox());
  std::vector<Camera> cams;
  std::vector<CameraImage> images;
  for (const CameraMap& v : views) {
    cams.push_back(v.camera);
    cv::Mat img(v.map.size(), CV_8UC3);
    cv::randu(img, cv::Scalar::all(0), cv::Scalar::all(255));
    images.push_back({v.camera, img});
  }
  const HullVisibility vis = ComputeHullVisibility(q, cams, 80, {}, 6, 1);
  const cv::Rect whole(0, 0, 320, 240);
  for (const NovelView& view : ThinPartsEyes(320, 240)) {
    PlaneSweepOptions o;
    o.num_planes = 100;
    const auto depths = SweepPlaneDepths(q, view, o);
    SweepBounds b1;
    ASSERT_TRUE(SweepDepthBounds(q, view, whole, depths, true, &b1, nullptr, 1));
    ASSERT_GT(cv::countNonZero(b1.hit_near <= b1.hit_far), 10);
    for (const int refine : {0, 6}) {
      SweepStats s1;
      const cv::Mat d1 = PlaneSweepCpu(q, view, depths, whole, &s1, 1, refine);
      ASSERT_GT(cv::countNonZero(d1 == d1), 1000) << "refine " << refine << ": the view sees hull";
      const cv::Mat c1 = TextureHull(d1, whole, view, images, {}, &vis, nullptr, 1);
      for (const int threads : {2, 3}) {
        const std::string what = std::to_string(threads) + " threads, refine " + std::to_string(refine);
        SweepBounds bt;
        ASSERT_TRUE(SweepDepthBounds(q, view, whole, depths, true, &bt, nullptr, threads));
        for (const auto& [m1, mt] : {std::pair{b1.near, bt.near}, {b1.far, bt.far}, {b1.hit_near, bt.hit_near},
                                     {b1.hit_far, bt.hit_far}})
          EXPECT_EQ(std::memcmp(m1.data, mt.data, m1.total() * m1.elemSize()), 0) << what;
        SweepStats st;
        const cv::Mat dt = PlaneSweepCpu(q, view, depths, whole, &st, threads, refine);
        EXPECT_EQ(std::memcmp(d1.data, dt.data, d1.total() * d1.elemSize()), 0) << what;
        EXPECT_EQ(s1.rays, st.rays) << what;
        EXPECT_EQ(cv::norm(c1, TextureHull(dt, whole, view, images, {}, &vis, nullptr, threads), cv::NORM_INF), 0.0)
            << what;
      }
    }
  }
}

// Runs of plane points one camera puts on background are skipped whole
// (VolumeQueryOptions::skip_background_runs): on the thin parts scene, rings of
// 4 and 5 cameras, pinhole, mildly distorted and with the Utrecht rig's lenses,
// three views, 30 to 300 planes, with and without refinement, the depth images
// are the same to the bit as the sweep that asks every point. The near misses
// in skipped runs are counted only when a scannable near miss's place among
// the first eight depends on it; dense planes make rays with more than eight,
// and leaving those counts out changes pixels here. Positive control: points
// were skipped under every lens, and most projections saved.
TEST(BackgroundRuns, SkippedRunsChangeNoPixel) {
  for (const int ncam : {4, 5}) {
    for (const int lens : {0, 1, 2}) {
      const std::vector<CameraMap> views = ThinPartsViews(ncam, lens, 0.06 * lens);
      VolumeQueryOptions on, off;
      off.skip_background_runs = false;
      const VolumeQuery qa(views, test::BigBox(), on), qb(views, test::BigBox(), off);
      int64_t skipped = 0, visited = 0, saved = 0, asked = 0;
      SCOPED_TRACE("lens " + std::to_string(lens));
      CompareThinPartsSweeps(qa, qb, 200, 150, [&](const SweepStats& sa, const SweepStats& sb, const std::string& w) {
        EXPECT_EQ(sb.run_skipped, 0) << w;
        EXPECT_EQ(sa.plane_points, sb.plane_points) << w << ": every point visited or skipped";
        skipped += sa.run_skipped;
        visited += sa.plane_points;
        saved += sb.projections - sa.projections;
        asked += sb.projections;
      });
      const std::string what = std::to_string(ncam) + " cameras, lens " + std::to_string(lens);
      EXPECT_GT(skipped, visited / 10) << what;
      EXPECT_GT(saved, asked / 5) << what;
    }
  }
}

}  // namespace
}  // namespace hullpipe
