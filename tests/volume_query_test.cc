// Volume query, hull box, CPU plane sweep and triangle query against exact
// ground truth: an analytic sphere seen by ring cameras with exact maps.
#include "hullpipe/volume_query.h"

#include <cmath>
#include <cstring>

#include <gtest/gtest.h>

#include "hullpipe/ball_scene.h"
#include "hullpipe/collision.h"
#include "hullpipe/conventions.h"
#include "hullpipe/plane_sweep.h"
#include "hullpipe/synthetic.h"
#include "hullpipe/triangle_query.h"
#include "test_util.h"

namespace hullpipe {
namespace {

const Eigen::Vector3d kCentre(0.1, -0.2, -1.0);
constexpr double kRadius = 0.3;

class SphereHull : public ::testing::Test {
 protected:
  SphereHull() : query_(test::SphereViews(4, 320, 240, kCentre, kRadius), test::BigBox()) {}
  VolumeQuery query_;
};

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

NovelView SideView() {
  return NovelView::FromFov(160, 120, 0.8,
                            LookAt(kCentre + Eigen::Vector3d(2.0, 1.2, -0.5), kCentre, Eigen::Vector3d(0, 0, -1)));
}

// Reference sweep: every plane of every pixel tested with the double-precision
// Inside(), front to back. The fast sweep (floats, box clipping, camera
// reordering) must give the same plane except where float rounding moves a plane
// point across a silhouette border: then one plane apart at most.
TEST_F(SphereHull, CpuSweepEqualsBruteForcePlaneByPlane) {
  const NovelView view = SideView();
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
  const NovelView view = SideView();
  PlaneSweepOptions o;
  o.num_planes = 200;
  const auto depths = SweepPlaneDepths(query_, view, o);
  const double spacing = depths[1] - depths[0];
  const cv::Mat d = PlaneSweepCpu(query_, view, depths, {0, 0, view.width, view.height}, nullptr, 2);
  const Shape sphere = Shape::Sphere(kCentre, kRadius);
  int hits = 0;
  for (int r = 0; r < view.height; ++r)
    for (int c = 0; c < view.width; ++c) {
      const Eigen::Vector3d D = view.world_from_eye.rotation * view.EyeRay(c + 0.5, r + 0.5);
      const auto s = Shape::Sphere(kCentre, kRadius - 0.03).Intersect(view.world_from_eye.translation, D);
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
  const NovelView view = SideView();
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
  const VolumeQuery q(test::SphereViews(4, 160, 120, kCentre, kRadius), test::BigBox());
  // A view from inside the hull box, looking through the sphere's centre.
  const NovelView view = NovelView::FromFov(80, 60, 1.5, LookAt(kCentre + Eigen::Vector3d(0.05, 0, 0), kCentre + Eigen::Vector3d(1, 0, 0), {0, 0, -1}));
  const cv::Mat d = PlaneSweepCpu(q, view, SweepPlaneDepths(q, view, {}), {0, 0, 80, 60});
  for (auto it = d.begin<float>(); it != d.end<float>(); ++it) EXPECT_TRUE(!std::isnan(*it) && *it > 0);
}

TEST_F(SphereHull, TriangleInsideCollidesEverywhere) {
  const Eigen::Vector3d a = kCentre + Eigen::Vector3d(-0.05, 0, 0), b = kCentre + Eigen::Vector3d(0.05, 0, 0),
                        c = kCentre + Eigen::Vector3d(0, 0.06, 0.02);
  const auto r = QueryTriangleCpu(query_, a, b, c);
  EXPECT_GT(r.pixels_tested, 100);  // 10 cm triangle, 2 mm pixels
  EXPECT_EQ(int(r.collision_points.size()), r.pixels_tested);
}

TEST_F(SphereHull, TriangleCuttingTheHullGivesPointsOnTriangleInsideHull) {
  const Eigen::Vector3d a = kCentre + Eigen::Vector3d(-0.5, -0.1, 0), b = kCentre + Eigen::Vector3d(0.5, -0.1, 0),
                        c = kCentre + Eigen::Vector3d(0, 0.5, 0.1);
  const auto r = QueryTriangleCpu(query_, a, b, c, {0.01, 0, 64});
  ASSERT_FALSE(r.collision_points.empty());
  EXPECT_LT(int(r.collision_points.size()), r.pixels_tested);
  const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
  for (const auto& p : r.collision_points) {
    EXPECT_NEAR(n.dot(p - a), 0, 1e-9);  // on the triangle's plane
    EXPECT_TRUE(query_.Inside(p));
    EXPECT_LT((p - kCentre).norm(), 2 * kRadius);
  }
}

TEST_F(SphereHull, TriangleFarAwayAndTinyAndSliver) {
  const Eigen::Vector3d off(2, 2, 0);
  EXPECT_TRUE(QueryTriangleCpu(query_, kCentre + off, kCentre + off + Eigen::Vector3d(0.1, 0, 0),
                               kCentre + off + Eigen::Vector3d(0, 0.1, 0))
                  .collision_points.empty());
  // Smaller than a pixel: still queried (at its centroid).
  const auto tiny = QueryTriangleCpu(query_, kCentre, kCentre + Eigen::Vector3d(1e-4, 0, 0),
                                     kCentre + Eigen::Vector3d(0, 1e-4, 0));
  EXPECT_EQ(tiny.pixels_tested, 1);
  EXPECT_EQ(tiny.collision_points.size(), 1u);
  // A 1000:1 sliver through the centre.
  const auto sliver = QueryTriangleCpu(query_, kCentre - Eigen::Vector3d(0.1, 0, 0), kCentre + Eigen::Vector3d(0.1, 0, 0),
                                       kCentre + Eigen::Vector3d(0, 0.0002, 0));
  EXPECT_GE(sliver.pixels_tested, 1);
  EXPECT_FALSE(sliver.collision_points.empty());
  // Degenerate (zero area): no crash, centroid tested.
  const auto degenerate = QueryTriangleCpu(query_, kCentre, kCentre, kCentre);
  EXPECT_EQ(degenerate.pixels_tested, 1);
}

TEST(Collision, BoxTestSkipsDistantMeshes) {
  const VolumeQuery q(test::SphereViews(4, 160, 120, kCentre, kRadius), test::BigBox());
  Rigid3d far;
  far.translation = kCentre + Eigen::Vector3d(3, 0, 0);
  const auto r = DetectCollisions(q, TriangleMesh::Icosphere(0.1, 1).Transformed(far));
  EXPECT_FALSE(r.box_overlap);
  EXPECT_EQ(r.triangles_queried, 0);
  Rigid3d touching;
  touching.translation = kCentre + Eigen::Vector3d(kRadius + 0.05, 0, 0);
  const auto t = DetectCollisions(q, TriangleMesh::Icosphere(0.1, 2).Transformed(touching));
  EXPECT_TRUE(t.colliding());
}

TEST(BallSimulation, BouncesOffTheHullAndIsDeterministic) {
  const VolumeQuery q(test::SphereViews(4, 160, 120, kCentre, kRadius), test::BigBox());
  SceneConfig cfg;
  cfg.has_floor = false;
  cfg.gravity.setZero();
  cfg.balls[0].start = kCentre + Eigen::Vector3d(1.5, 0, 0);
  cfg.balls[0].target = kCentre;
  cfg.balls[0].flight_time = 1.0;
  cfg.balls[0].rethrow_period = 0;
  BallSimulation a(cfg), b(cfg);
  bool collided = false;
  for (int i = 0; i < 60; ++i) {
    a.Step(0.02, &q);
    b.Step(0.02, &q);
    const BodyState& s = a.bodies()[0];
    collided |= s.colliding;
    ASSERT_EQ(s.position, b.bodies()[0].position);  // bit-identical
    if (s.colliding) {
      // The §4 response moved the ball out along V_rec: its deepest collision
      // point is back on the hull's surface, and N_hull faces the ball.
      ASSERT_TRUE(s.last_response.has_value());
      EXPECT_GT(s.last_response->n_hull.dot(s.last_response->v_rec), 0);
      EXPECT_LT(s.last_response->d_rec, s.radius);
    }
  }
  EXPECT_TRUE(collided);
  EXPECT_GT(a.bodies()[0].velocity.x(), 0);  // moving away from the sphere again
  EXPECT_GT(a.bodies()[0].position.x(), kCentre.x() + kRadius);
}

TEST(BallSimulation, AFastBallDoesNotTunnelThroughAThinHull) {
  // A 1 cm plate; a ball of radius 5 cm at 20 m/s moves 80 cm per 40 ms frame,
  // 20 cm per 10 ms time substep: without spatial substeps it would pass through.
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Box(kCentre, {0.005, 0.3, 0.3}));
  std::vector<CameraMap> views;
  for (const auto& c : RingCameras(4, 3.0, 1.8, kCentre, 640, 480, 1.0)) views.push_back({c, RenderExactMap(c, scene)});
  const VolumeQuery q(views, test::BigBox());
  SceneConfig cfg;
  cfg.has_floor = false;
  cfg.gravity.setZero();
  cfg.balls[0].radius = 0.05;
  cfg.balls[0].start = kCentre + Eigen::Vector3d(1.2, 0, 0);
  cfg.balls[0].target = kCentre - Eigen::Vector3d(1.8, 0, 0);
  cfg.balls[0].flight_time = 0.15;  // 3 m in 0.15 s: 20 m/s
  cfg.balls[0].rethrow_period = 0;
  BallSimulation sim(cfg);
  bool collided = false;
  for (int i = 0; i < 10; ++i) {
    sim.Step(0.04, &q);
    collided |= sim.bodies()[0].colliding;
    ASSERT_GT(sim.bodies()[0].position.x(), kCentre.x()) << "frame " << i << ": the ball got through";
  }
  EXPECT_TRUE(collided);
  EXPECT_GT(sim.bodies()[0].velocity.x(), 0) << "bounced back";
}

}  // namespace
}  // namespace hullpipe
