// CP_hull and N_hull by exact means against analytic ground truth: a sphere's
// visual hull is the intersection of the cameras' cones tangent to the sphere, so
// the hull's surface normal at a point on camera c's cone is that cone's normal.
#include "hullpipe/collision/hull_surface.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "hullpipe/collision/collision.h"
#include "hullpipe/collision/collision_response.h"
#include "hullpipe/geometry/mesh.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

// The test sphere of the shared fixtures (SphereViews, SphereHull, SphereSideView).
using test::kSphereCentre;
using test::kSphereRadius;

// Outward normal at X of the cone from camera centre C tangent to the sphere.
Eigen::Vector3d ConeNormalAt(const Eigen::Vector3d& C, const Eigen::Vector3d& X) {
  const Eigen::Vector3d a = (kSphereCentre - C).normalized(), d = (X - C).normalized();
  return -(a - a.dot(d) * d).normalized();
}

TEST(HullSurface, FirstHullPointIsWhereStepsFirstEnterTheHull) {
  const VolumeQuery q(test::SphereViews(4, 320, 240, kSphereCentre, kSphereRadius), test::BigBox());
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  int hits = 0;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d o = kSphereCentre + Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized() * 1.0;
    const Eigen::Vector3d dir = (kSphereCentre + Eigen::Vector3d(u(rng), u(rng), u(rng)) * 0.2 - o).normalized();
    const auto cp = FirstHullPointAlong(q, o, dir, 2.0);
    // Step at 0.1 mm: the first inside sample is at most one step past CP_hull.
    double first = -1;
    for (double s = 0; s <= 2.0; s += 1e-4)
      if (q.Inside(o + s * dir)) {
        first = s;
        break;
      }
    ASSERT_EQ(cp.has_value(), first >= 0) << i;
    if (!cp) continue;
    ++hits;
    const double s_cp = (*cp - o).dot(dir);
    EXPECT_LE(s_cp, first + 1e-9);
    EXPECT_GE(s_cp, first - 1e-4 - 1e-9);
  }
  EXPECT_GT(hits, 100);
  EXPECT_FALSE(FirstHullPointAlong(q, kSphereCentre + Eigen::Vector3d(5, 0, 0), {1, 0, 0}, 3.0).has_value());
}

TEST(HullSurface, SampledCrossingsAgreeWithTheExactIntervals) {
  const VolumeQuery q(test::SphereViews(4, 320, 240, kSphereCentre, kSphereRadius), test::BigBox());
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int k = 0; k < 30; ++k) {
    const Eigen::Vector3d o = kSphereCentre + Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized() * 1.0;
    const Eigen::Vector3d d = kSphereCentre - o;  // not unit: s in its units
    const auto exact = FirstHullPointAlong(q, o, d, 1.0);
    const auto in = FirstSampledCrossing(q, o, d, 0.0, 1.0, /*inside=*/true, 0.002, 1e-5);
    ASSERT_EQ(exact.has_value(), in.has_value());
    if (!exact) continue;
    // The entry: within the bisection tolerance (the hull is thicker than a step).
    EXPECT_LT((o + *in * d - *exact).norm(), 1e-5 + 1e-9);
    EXPECT_TRUE(q.Inside(o + *in * d));
    // And leaving from the centre along the reverse direction reaches the same
    // surface point (a sphere's hull is convex).
    const auto out = FirstSampledCrossing(q, kSphereCentre, -d, 0.0, 1.0, /*inside=*/false, 0.002, 1e-5);
    ASSERT_TRUE(out.has_value());
    EXPECT_FALSE(q.Inside(kSphereCentre - *out * d));
  }
  // Already of the wanted kind at s_begin; never of it.
  EXPECT_EQ(FirstSampledCrossing(q, kSphereCentre, {1, 0, 0}, 0.0, 1.0, true, 0.002, 1e-5).value(), 0.0);
  EXPECT_FALSE(
      FirstSampledCrossing(q, kSphereCentre + Eigen::Vector3d(5, 0, 0), {1, 0, 0}, 0.0, 1.0, true, 0.002, 1e-5));
}

TEST(HullSurface, NormalFromTheSilhouetteEdgeMatchesTheAnalyticCone) {
  // 640x480 cameras 3 m away: the sphere's silhouette is ~90 px across. The
  // normal comes from a line fitted to the border pixels within 3 px, so its
  // error is the pixel staircase's: a few degrees.
  const auto views = test::SphereViews(4, 640, 480, kSphereCentre, kSphereRadius);
  const VolumeQuery q(views, test::BigBox());
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> err_deg;
  int edges = 0;
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d o = kSphereCentre + Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized() * 1.0;
    const auto cp = FirstHullPointAlong(q, o, kSphereCentre - o, 1.0);
    ASSERT_TRUE(cp.has_value());
    const auto n = HullSurfaceNormal(q, *cp);
    ASSERT_TRUE(n.has_value()) << "a hull surface point lies on some camera's border";
    EXPECT_NEAR(n->normal.norm(), 1.0, 1e-9);
    EXPECT_GT(n->normal.dot((o - *cp).normalized()), 0) << "outward: toward where the search came from";
    if (n->edge) {
      ++edges;
      continue;
    }
    const Eigen::Vector3d truth = ConeNormalAt(views[size_t(n->camera)].camera.Center(), *cp);
    err_deg.push_back(std::acos(std::clamp(truth.dot(n->normal), -1.0, 1.0)) * 180 / M_PI);
  }
  ASSERT_GT(err_deg.size(), 150u);
  std::sort(err_deg.begin(), err_deg.end());
  const double median = err_deg[err_deg.size() / 2], p95 = err_deg[err_deg.size() * 95 / 100];
  std::printf("N_hull error: median %.2f deg, p95 %.2f deg, %d of 300 on hull edges\n", median, p95, edges);
  EXPECT_LT(median, 3.0);
  EXPECT_LT(p95, 10.0);
}

TEST(HullSurface, PointAwayFromTheSurfaceHasNoNormal) {
  const VolumeQuery q(test::SphereViews(4, 320, 240, kSphereCentre, kSphereRadius), test::BigBox());
  EXPECT_FALSE(HullSurfaceNormal(q, kSphereCentre).has_value()) << "deep inside: no border near";
  HullNormalOptions bad;
  bad.border_px = 0;
  EXPECT_THROW(HullSurfaceNormal(q, kSphereCentre, bad), std::invalid_argument);
}

}  // namespace
}  // namespace hullpipe
