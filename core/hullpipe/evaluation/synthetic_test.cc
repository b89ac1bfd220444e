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

TEST(Synthetic, TorusIntersectIsTheFirstSurfacePoint) {
  const Shape torus = Shape::Torus(kCentre, 0.25, 0.08,
                                   Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix());
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  int hits = 0;
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d o = kCentre + Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized() * 1.5;
    const Eigen::Vector3d d = kCentre + Eigen::Vector3d(u(rng), u(rng), u(rng)) * 0.3 - o;
    const auto s = torus.Intersect(o, d);
    // No sample before the hit is inside (1 mm steps along a 1.5 m ray).
    const double end = s ? *s : 2.0;
    for (double t = 0; t < end - 1e-6; t += 0.001 / d.norm()) ASSERT_GT(torus.SignedDistance(o + t * d), -1e-9);
    if (!s) continue;
    ++hits;
    EXPECT_NEAR(torus.SignedDistance(o + *s * d), 0.0, 1e-9);
    EXPECT_NEAR(torus.Normal(o + *s * d).norm(), 1.0, 1e-12);
  }
  EXPECT_GT(hits, 100);
}

TEST(Synthetic, EveryNamedSceneIsInsideItsExactHull) {
  // The visual hull contains the object: every shape point (sampled on a grid)
  // whose projection is well inside each silhouette is inside the hull.
  for (const char* name : {"sphere", "box", "torus", "hand", "mixed"}) {
    const SyntheticScene scene = NamedScene(name, 0.7);
    std::vector<CameraMap> views;
    for (const auto& c : DomeCameras(6, 3.0, {0, 0, -1.0}, 320, 240, 0.9))
      views.push_back({c, RenderExactMap(c, scene)});
    const VolumeQuery q(views, test::BigBox());
    int inside = 0;
    for (double x = -0.5; x <= 0.5; x += 0.01)
      for (double y = -0.5; y <= 0.5; y += 0.01)
        for (double z = -1.5; z <= -0.5; z += 0.01) {
          const Eigen::Vector3d p(x, y, z);
          // More than one pixel footprint (3.5 m * 0.97 / 320 = 11 mm) inside a shape.
          double sd = 1e9;
          for (const auto& sh : scene.shapes) sd = std::min(sd, sh.SignedDistance(p));
          if (sd > -0.012) continue;
          ++inside;
          ASSERT_TRUE(q.Inside(p)) << name << " " << p.transpose();
        }
    EXPECT_GT(inside, 10) << name;
  }
}

}  // namespace
}  // namespace hullpipe
