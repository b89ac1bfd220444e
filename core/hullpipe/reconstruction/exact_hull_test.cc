// The exact ray–hull reference (image-based visual hull) against point queries,
// the plane sweep against the exact reference, depth refinement, and the hard
// cases, each with its exact expected result.
#include "hullpipe/reconstruction/exact_hull.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Geometry>

#include <gtest/gtest.h>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/evaluation/depth_eval.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/texture.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

// The test sphere of the shared fixtures (SphereViews, SphereHull, SphereSideView).
const Eigen::Vector3d& kCentre = test::kSphereCentre;
constexpr double kRadius = test::kSphereRadius;



// Membership from the exact intervals equals VolumeQuery::Inside at every sample,
// except within 1e-9 m of an interval boundary (where the double-precision
// projection of the sample and of the crossing may round differently).
void ExpectIntervalsMatchInside(const VolumeQuery& q, int rays, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  int inside_samples = 0;
  for (int r = 0; r < rays; ++r) {
    const Eigen::Vector3d o = kCentre + Eigen::Vector3d(u(rng), u(rng), u(rng)) * 1.5;
    const Eigen::Vector3d target = kCentre + Eigen::Vector3d(u(rng), u(rng), u(rng)) * 0.35;
    const Eigen::Vector3d dir = target - o;
    const Intervals iv = RayHullIntervals(q, o, dir, 0.0, 2.0);
    for (size_t k = 1; k + 1 < iv.size(); ++k) ASSERT_LT(iv[k - 1].second, iv[k].first) << "sorted, disjoint";
    for (int i = 0; i <= 400; ++i) {
      const double s = 2.0 * i / 400.0;
      if (test::DistanceToBoundary(iv, s) * dir.norm() < 1e-9) continue;
      const bool inside = q.Inside(o + s * dir);
      inside_samples += inside;
      ASSERT_EQ(test::InIntervals(iv, s), inside) << "ray " << r << " s " << s << " boundary at "
                                            << test::DistanceToBoundary(iv, s) << " n=" << iv.size();
    }
  }
  EXPECT_GT(inside_samples, 100);
}

TEST(ExactHull, IntervalsEqualPointQueriesUndistorted) {
  ExpectIntervalsMatchInside(VolumeQuery(test::SphereViews(4, 160, 120, kCentre, kRadius), test::BigBox()), 60, 1);
}

TEST(ExactHull, IntervalsEqualPointQueriesDistorted) {
  const Distortion d{-0.25, 0.08, 0.001, -0.001, -0.01};
  ExpectIntervalsMatchInside(VolumeQuery(test::SphereViews(4, 160, 120, kCentre, kRadius, d), test::BigBox()), 30,
                             2);
}

TEST(ExactHull, IntervalsEqualPointQueriesUnderBothPolicies) {
  for (const OutOfView p : {OutOfView::kOutside, OutOfView::kUnknown}) {
    VolumeQueryOptions o;
    o.out_of_view = p;
    // Narrow cameras (0.35 rad) so the sphere is partly outside some images.
    SyntheticScene scene;
    scene.shapes.push_back(Shape::Sphere(kCentre, kRadius));
    std::vector<CameraMap> views;
    for (const auto& c : RingCameras(4, 2.0, 1.8, kCentre + Eigen::Vector3d(0.2, 0, 0), 120, 90, 0.35))
      views.push_back({c, RenderExactMap(c, scene)});
    ExpectIntervalsMatchInside(VolumeQuery(views, test::BigBox(), o), 40, 3);
  }
}

// The hull's reach along a direction that is no axis (a rig whose up is
// tilted): against a dense reference (exact intervals along lines 2 mm apart
// across the hull, then 0.2 mm apart around the best), within 0.5 mm (the
// extreme is a corner where the cameras' silhouette cones meet: lines 0.3 mm
// apart around it come within a fraction of a millimetre of its reach).
// The hull box's corner, the old floor, is ~20 cm off.
TEST(HullExtentAlong, ReachesTheHullsExtremePointAlongATiltedDirection) {
  const Eigen::Vector3d centre(0.1, -0.2, -1.0);
  const VolumeQuery q(test::SphereViews(6, 240, 180, centre, 0.3), test::BigBox());
  const Eigen::Vector3d dir = Eigen::Vector3d(1, 1, 1).normalized();
  const auto got = HullExtentAlong(q, dir);
  ASSERT_TRUE(got.has_value());
  // Reference: lines along dir through a 4 mm grid across the hull's section,
  // then a 0.2 mm grid within 5 mm of the best.
  const Eigen::Vector3d a = dir.unitOrthogonal(), b = dir.cross(a);
  const Eigen::Vector3d start = centre - 1.0 * dir;
  double ref = -1e300, bx = 0, by = 0;
  auto reach = [&](double x, double y) {
    for (const auto& iv : RayHullIntervals(q, start + x * a + y * b, dir, 0, 2.0))
      if (dir.dot(start + x * a + y * b) + iv.second > ref) ref = dir.dot(start + x * a + y * b) + iv.second, bx = x, by = y;
  };
  for (double x = -0.36; x <= 0.36; x += 0.004)
    for (double y = -0.36; y <= 0.36; y += 0.004) reach(x, y);
  const double cx = bx, cy = by;
  for (double x = cx - 0.005; x <= cx + 0.005; x += 0.0002)
    for (double y = cy - 0.005; y <= cy + 0.005; y += 0.0002) reach(x, y);
  EXPECT_GE(ref, dir.dot(centre) + 0.3 - 1e-9);  // a sphere's hull holds the sphere
  EXPECT_NEAR(*got, ref, 0.0005);  // both a hull point's reach, each exact along its lines
  double corner = -1e300;
  for (const auto& p : q.hull_box().Corners()) corner = std::max(corner, dir.dot(p));
  EXPECT_GT(corner - ref, 0.1) << "the box corner is no floor for a tilted up";
  EXPECT_THROW(HullExtentAlong(q, Eigen::Vector3d::Zero()), std::invalid_argument);
}

}  // namespace
}  // namespace hullpipe
