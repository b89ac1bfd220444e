// Volume query, hull box, CPU plane sweep and triangle query against exact
// ground truth: an analytic sphere seen by ring cameras with exact maps.
#include "hullpipe/reconstruction/volume_query.h"

#include <cmath>
#include <cstring>

#include <gtest/gtest.h>

#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/scenes/ball.h"
#include "hullpipe/collision/collision.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/collision/triangle_query.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

// The test sphere of the shared fixtures (SphereViews, SphereHull, SphereSideView).
using test::kSphereCentre;
using test::kSphereRadius;

using test::SphereHull;

TEST_F(SphereHull, TriangleInsideCollidesEverywhere) {
  const Eigen::Vector3d a = kSphereCentre + Eigen::Vector3d(-0.05, 0, 0),
                        b = kSphereCentre + Eigen::Vector3d(0.05, 0, 0),
                        c = kSphereCentre + Eigen::Vector3d(0, 0.06, 0.02);
  const auto r = QueryTriangleCpu(query_, a, b, c);
  EXPECT_GT(r.pixels_tested, 100);  // 10 cm triangle, 2 mm pixels
  EXPECT_EQ(int(r.collision_points.size()), r.pixels_tested);
}

TEST_F(SphereHull, TriangleCuttingTheHullGivesPointsOnTriangleInsideHull) {
  const Eigen::Vector3d a = kSphereCentre + Eigen::Vector3d(-0.5, -0.1, 0),
                        b = kSphereCentre + Eigen::Vector3d(0.5, -0.1, 0),
                        c = kSphereCentre + Eigen::Vector3d(0, 0.5, 0.1);
  const auto r = QueryTriangleCpu(query_, a, b, c, {0.01, 0, 64});
  ASSERT_FALSE(r.collision_points.empty());
  EXPECT_LT(int(r.collision_points.size()), r.pixels_tested);
  const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
  for (const auto& p : r.collision_points) {
    EXPECT_NEAR(n.dot(p - a), 0, 1e-9);  // on the triangle's plane
    EXPECT_TRUE(query_.Inside(p));
    EXPECT_LT((p - kSphereCentre).norm(), 2 * kSphereRadius);
  }
}

// A triangle far larger than any viewport: its pixel counts clamp in floating
// point before they become ints (CeilPixel), to the largest viewport.
TEST_F(SphereHull, AHugeTriangleGetsTheLargestViewport) {
  TriangleQueryOptions o;
  const auto r = QueryTriangleCpu(query_, kSphereCentre, kSphereCentre + Eigen::Vector3d(1e15, 0, 0),
                                  kSphereCentre + Eigen::Vector3d(0, 1e15, 0), o);
  EXPECT_LE(r.pixels_tested, o.max_viewport * o.max_viewport);
}

TEST_F(SphereHull, TriangleFarAwayAndTinyAndSliver) {
  const Eigen::Vector3d off(2, 2, 0);
  EXPECT_TRUE(QueryTriangleCpu(query_, kSphereCentre + off, kSphereCentre + off + Eigen::Vector3d(0.1, 0, 0),
                               kSphereCentre + off + Eigen::Vector3d(0, 0.1, 0))
                  .collision_points.empty());
  // Smaller than a pixel: still queried (at its centroid).
  const auto tiny = QueryTriangleCpu(query_, kSphereCentre, kSphereCentre + Eigen::Vector3d(1e-4, 0, 0),
                                     kSphereCentre + Eigen::Vector3d(0, 1e-4, 0));
  EXPECT_EQ(tiny.pixels_tested, 1);
  EXPECT_EQ(tiny.collision_points.size(), 1u);
  // A 1000:1 sliver through the centre.
  const auto sliver =
      QueryTriangleCpu(query_, kSphereCentre - Eigen::Vector3d(0.1, 0, 0), kSphereCentre + Eigen::Vector3d(0.1, 0, 0),
                       kSphereCentre + Eigen::Vector3d(0, 0.0002, 0));
  EXPECT_GE(sliver.pixels_tested, 1);
  EXPECT_FALSE(sliver.collision_points.empty());
  // Degenerate (zero area): no crash, centroid tested.
  const auto degenerate = QueryTriangleCpu(query_, kSphereCentre, kSphereCentre, kSphereCentre);
  EXPECT_EQ(degenerate.pixels_tested, 1);
}

}  // namespace
}  // namespace hullpipe
