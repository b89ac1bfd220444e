// Thrown balls (paper §4) against exact synthetic hulls: a bounce off the
// hull, deterministic; a fast ball not tunnelling through a thin hull; a bounce
// off a box face whose hull face is exact, against the exact reflection.
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

TEST(BallAndBlocks, BounceOffABoxFaceIsTheExactReflection) {
  // A real block: an axis-aligned box. Two cameras lie in the plane of its face
  // x = +0.2, so that face is exactly a face of the visual hull (its silhouette
  // edge back-projects into that plane); a third looks from above.
  const Eigen::Vector3d c(0, 0, -1.0);
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Box(c, Eigen::Vector3d(0.2, 0.3, 0.3)));
  const std::vector<Camera> cams = {
      test::LookAtCamera(1, c + Eigen::Vector3d(0.2, -3.0, 0.1), c + Eigen::Vector3d(0.2, 0, 0), 640, 480, 0.5),
      test::LookAtCamera(2, c + Eigen::Vector3d(0.2, 3.0, -0.1), c + Eigen::Vector3d(0.2, 0, 0), 640, 480, 0.5),
      test::LookAtCamera(3, c + Eigen::Vector3d(1.5, 0.3, -2.5), c, 640, 480, 0.6)};
  const VolumeQuery q = test::HullOf(scene, cams);
  SceneConfig cfg;
  cfg.gravity = Eigen::Vector3d::Zero();
  cfg.has_floor = false;
  cfg.balls.clear();
  for (double restitution : {1.0, 0.6}) {
    BallConfig b;
    b.radius = 0.05;
    b.start = c + Eigen::Vector3d(0.8, -0.3, 0.05);
    b.target = c + Eigen::Vector3d(0.2, 0.05, 0.0);  // on the face
    b.flight_time = 0.5;
    b.restitution = restitution;
    b.rethrow_period = 0;
    cfg.balls = {b};
    BallSimulation sim(cfg);
    const Eigen::Vector3d v_in = sim.bodies()[0].velocity;
    bool bounced = false;
    for (int f = 0; f < 30 && !bounced; ++f) {
      sim.Step(1.0 / 30, &q);
      bounced = sim.bodies()[0].velocity.x() > 0;
    }
    ASSERT_TRUE(bounced);
    const Eigen::Vector3d n(1, 0, 0);
    const Eigen::Vector3d v_exact = v_in - (1 + restitution) * v_in.dot(n) * n;
    const Eigen::Vector3d v_out = sim.bodies()[0].velocity;
    const double angle = std::acos(std::clamp(v_out.normalized().dot(v_exact.normalized()), -1.0, 1.0)) * 180 / M_PI;
    // N_hull from the face's silhouette edge: a line fit over 6 px of a straight
    // edge, within ~1 degree; 2 degrees allows the fit's pixel rounding.
    EXPECT_LT(angle, 2.0) << "restitution " << restitution;
    EXPECT_NEAR(v_out.norm(), v_exact.norm(), 0.03 * v_in.norm());
    // The ball ends outside the hull.
    EXPECT_FALSE(q.Inside(sim.bodies()[0].position));
  }
}

}  // namespace
}  // namespace hullpipe
