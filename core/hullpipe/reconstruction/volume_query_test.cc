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
const Eigen::Vector3d& kCentre = test::kSphereCentre;
constexpr double kRadius = test::kSphereRadius;

using test::SphereHull;

TEST_F(SphereHull, PointsInsideTheSphereAreInside) {
  // The hull contains the sphere; a point deeper than ~2 pixel footprints
  // (3 m * 2 / 277 px = 2.2 cm) inside it projects onto object pixels everywhere.
  for (double x = -1; x <= 1; x += 0.25)
    for (double y = -1; y <= 1; y += 0.25)
      for (double z = -1; z <= 1; z += 0.25) {
        const Eigen::Vector3d p = kCentre + Eigen::Vector3d(x, y, z) * (kRadius - 0.025) / std::sqrt(3.0);
        EXPECT_TRUE(query_.Inside(p)) << p.transpose();
        EXPECT_EQ(query_.Count(p), 4);
      }
}

TEST_F(SphereHull, PointsFarOutsideAreOutside) {
  EXPECT_FALSE(query_.Inside(kCentre + Eigen::Vector3d(1, 0, 0)));
  EXPECT_FALSE(query_.Inside(kCentre + Eigen::Vector3d(0, 0, 0.6)));
  // Behind every camera: outside, never mirrored onto object pixels.
  for (const auto& v : query_.views()) {
    const Eigen::Vector3d c = v.camera.Center();
    const Eigen::Vector3d mirror = c - (kCentre - c);
    EXPECT_FALSE(query_.Inside(mirror));
  }
}

TEST_F(SphereHull, HullBoxContainsTheSphereAndIsTight) {
  const Aabb& box = query_.hull_box();
  ASSERT_FALSE(box.empty());
  EXPECT_TRUE((box.min.array() <= (kCentre.array() - kRadius)).all()) << box.min.transpose();
  EXPECT_TRUE((box.max.array() >= (kCentre.array() + kRadius)).all()) << box.max.transpose();
  // Four cameras carve the pyramids' intersection to well under twice the sphere.
  EXPECT_LT((box.max - box.min).maxCoeff(), 4 * kRadius);
}

TEST(HullBox, EmptyMapGivesEmptyBox) {
  auto views = test::SphereViews(3, 64, 48, kCentre, kRadius);
  views[1].map.setTo(0);
  const VolumeQuery q(views, test::BigBox());
  EXPECT_TRUE(q.hull_box().empty());
  EXPECT_FALSE(q.Inside(kCentre));
}

TEST(VolumeQuery, RejectsMapOfWrongSize) {
  auto views = test::SphereViews(2, 64, 48, kCentre, kRadius);
  views[0].map = cv::Mat(10, 10, CV_8UC1);
  EXPECT_THROW(VolumeQuery(views, test::BigBox()), std::invalid_argument);
}

}  // namespace
}  // namespace hullpipe
