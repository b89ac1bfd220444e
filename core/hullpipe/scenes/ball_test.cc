// Thrown balls (paper §4) against exact synthetic hulls: a bounce off the
// hull, deterministic; a fast ball not tunnelling through a thin hull; a bounce
// off a box face whose hull face is exact, against the exact reflection; a
// moving hull (a sphere at known speeds) throwing a resting ball.
#include "hullpipe/reconstruction/volume_query.h"

#include <cmath>
#include <cstring>
#include <functional>
#include <memory>

#include <gtest/gtest.h>

#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/scenes/ball.h"
#include "hullpipe/collision/collision.h"
#include "hullpipe/collision/hull_motion.h"
#include "hullpipe/collision/hull_surface.h"
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

// One ball and nothing else (no floor, no gravity, never thrown again), thrown
// from `start` to reach `target` after flight_time seconds.
SceneConfig OneBall(const Eigen::Vector3d& start, const Eigen::Vector3d& target, double flight_time,
                    double radius = BallConfig{}.radius, double restitution = BallConfig{}.restitution) {
  SceneConfig cfg;
  cfg.has_floor = false;
  cfg.gravity.setZero();
  BallConfig b;
  b.start = start;
  b.target = target;
  b.flight_time = flight_time;
  b.rethrow_period = 0;
  b.radius = radius;
  b.restitution = restitution;
  cfg.Set(BallsConfig({b}));
  return cfg;
}

// One ball of 5 cm radius at rest at `at`, nothing else.
SceneConfig RestingBall(const Eigen::Vector3d& at, double restitution = BallConfig{}.restitution) {
  return OneBall(at, at, BallConfig{}.flight_time, 0.05, restitution);
}

TEST(BallSimulation, BouncesOffTheHullAndIsDeterministic) {
  const VolumeQuery q(test::SphereViews(4, 160, 120, kCentre, kRadius), test::BigBox());
  const SceneConfig cfg = OneBall(kCentre + Eigen::Vector3d(1.5, 0, 0), kCentre, 1.0);
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
  const SceneConfig cfg = OneBall(kCentre + Eigen::Vector3d(1.2, 0, 0), kCentre - Eigen::Vector3d(1.8, 0, 0),
                                  0.15, 0.05);  // 3 m in 0.15 s: 20 m/s
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
  for (double restitution : {1.0, 0.6}) {
    BallConfig b;
    b.radius = 0.05;
    b.start = c + Eigen::Vector3d(0.8, -0.3, 0.05);
    b.target = c + Eigen::Vector3d(0.2, 0.05, 0.0);  // on the face
    b.flight_time = 0.5;
    b.restitution = restitution;
    b.rethrow_period = 0;
    cfg.Set(BallsConfig({b}));
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


// --- The hull's own motion (collision/hull_motion.h) ---------------------

// A sphere (the real object, r = 0.1 m) moving at `speed` along d towards a
// ball of radius 5 cm at rest (no gravity, no floor), filmed by four 1024x768
// cameras with exact maps that do not shoot together (fixed offsets and a
// jitter alternating frame to frame). The scene steps frame by frame against
// each frame's hull with the previous frame's hull as its motion.
struct Batting {
  double speed, fps;
};

class BatsABall : public testing::TestWithParam<Batting> {};

constexpr double kOffsetS[4] = {0.0, 0.003, -0.004, 0.005}, kJitterS[4] = {0.002, -0.002, 0.0015, -0.0015};

struct ShotFrame {
  std::unique_ptr<VolumeQuery> query;
  TimedHull timed;
};

ShotFrame ShootSphere(const std::vector<Camera>& cams, int k, double fps,
                      const std::function<SyntheticScene(double)>& at) {
  std::vector<CameraMap> views;
  std::vector<int64_t> skew_ns;
  const int64_t t_ref = int64_t(std::llround(k / fps * 1e9)) + 1'000'000'000;
  for (size_t i = 0; i < cams.size(); ++i) {
    const double skew = kOffsetS[i] + (k % 2 ? 1 : -1) * kJitterS[i];
    views.push_back({cams[i], RenderExactMap(cams[i], at(k / fps + skew))});
    skew_ns.push_back(int64_t(std::llround(skew * 1e9)));
  }
  ShotFrame f;
  f.query = std::make_unique<VolumeQuery>(views, test::BigBox());
  f.timed = TimedHull::Of(*f.query, t_ref, skew_ns);
  return f;
}

TEST_P(BatsABall, AtOnePlusRestitutionTimesTheSurfacesNormalSpeed) {
  const Batting b = GetParam();
  const Eigen::Vector3d c0(0, 0, -1.0), d = Eigen::Vector3d(1, 0.2, -0.1).normalized();
  const auto cams = RingCameras(4, 3.0, 1.6, c0, 1024, 768, 0.9);
  auto at = [&](double t) { return SyntheticScene{{Shape::Sphere(c0 + b.speed * t * d, 0.1)}}; };
  const ShotFrame first = ShootSphere(cams, 0, b.fps, at);
  const auto front = FirstHullPointAlong(*first.query, c0 + d, -d, 1.0);
  ASSERT_TRUE(front);
  const SceneConfig cfg = RestingBall(*front + (0.05 + 0.6 * b.speed / b.fps) * d, 0.5);  // struck in frame 1
  BallSimulation sim(cfg);
  ASSERT_EQ(sim.bodies()[0].velocity, Eigen::Vector3d::Zero());
  sim.Step(0, first.query.get());
  ShotFrame prev = ShootSphere(cams, 0, b.fps, at);
  int hits = 0;
  for (int k = 1; k <= 6; ++k) {
    ShotFrame cur = ShootSphere(cams, k, b.fps, at);
    const HullMotion motion(cur.timed, prev.timed);
    sim.Step(1 / b.fps, cur.query.get(), nullptr, &motion);
    const BodyState& s = sim.bodies()[0];
    if (s.colliding) {
      ++hits;
      ASSERT_TRUE(s.last_response);
      const CollisionResponse& r = *s.last_response;
      ASSERT_EQ(r.hull_velocity.status, HullVelocityStatus::kMeasured) << ToString(r.hull_velocity.status);
      // The rigid-body answer: a body at rest struck by a heavy surface moving
      // at w along its normal n leaves at (1 + e) w n; here w = V d . n. The
      // tolerance is (1 + e) times hull_motion_test's bound on w: 1.42 px of
      // silhouette quantization at the contact's depth over the interval,
      // plus 5% of V.
      const double w = b.speed * d.dot(r.n_hull);
      double footprint = 0;
      for (const auto& c : cams) footprint = std::max(footprint, (r.cp_hull - c.Center()).norm() / c.fx);
      const double bound = 1.5 * (1.42 * footprint * b.fps * 1.3 + 0.05 * b.speed);
      EXPECT_LT((s.velocity - 1.5 * w * r.n_hull).norm(), bound)
          << "frame " << k << ": " << s.velocity.transpose() << " vs " << (1.5 * w * r.n_hull).transpose();
      EXPECT_GT(s.velocity.dot(d), 1.2 * b.speed);  // thrown ahead, faster than the hand
    }
    prev = std::move(cur);
  }
  EXPECT_EQ(hits, 1) << "struck once, then ahead of the sphere";
}

INSTANTIATE_TEST_SUITE_P(Speeds, BatsABall,
                         testing::Values(Batting{0.5, 25}, Batting{1.0, 25}, Batting{1.0, 50}, Batting{3.0, 50}),
                         [](const testing::TestParamInfo<Batting>& i) {
                           return std::to_string(int(std::lround(i.param.speed * 10))) + "dmps_" +
                                  std::to_string(int(i.param.fps)) + "fps";
                         });

// Without the hull's motion the same ball is only pushed out, never thrown:
// the paper's response (the control that the test above measures the motion).
TEST(BallSimulation, WithoutTheHullsMotionARestingBallIsOnlyPushedOut) {
  const Eigen::Vector3d c0(0, 0, -1.0), d(1, 0, 0);
  const auto cams = RingCameras(4, 3.0, 1.6, c0, 640, 480, 0.9);
  auto at = [&](double t) { return SyntheticScene{{Shape::Sphere(c0 + 1.0 * t * d, 0.1)}}; };
  const ShotFrame first = ShootSphere(cams, 0, 25, at);
  const auto front = FirstHullPointAlong(*first.query, c0 + d, -d, 1.0);
  ASSERT_TRUE(front);
  const SceneConfig cfg = RestingBall(*front + 0.07 * d);
  BallSimulation sim(cfg);
  sim.Step(0, first.query.get());
  bool hit = false;
  for (int k = 1; k <= 3; ++k) {
    const ShotFrame cur = ShootSphere(cams, k, 25, at);
    sim.Step(0.04, cur.query.get());
    hit |= sim.bodies()[0].colliding;
    EXPECT_EQ(sim.bodies()[0].velocity, Eigen::Vector3d::Zero());
  }
  EXPECT_TRUE(hit);
}

// A hull that did not move gives exactly the paper's response: the same
// states, bit for bit, as a step without the hull's motion.
TEST(BallSimulation, AStationaryHullsMotionChangesNothing) {
  const auto views = test::SphereViews(4, 160, 120, kCentre, kRadius);
  const VolumeQuery q(views, test::BigBox()), q_prev(test::SphereViews(4, 160, 120, kCentre, kRadius), test::BigBox());
  const SceneConfig cfg = OneBall(kCentre + Eigen::Vector3d(1.5, 0.05, 0), kCentre, 1.0);
  BallSimulation a(cfg), b(cfg);
  int measured = 0;
  for (int i = 0; i < 60; ++i) {
    const int64_t t = 1'000'000'000 + int64_t(i) * 20'000'000;
    const HullMotion motion(TimedHull::Of(q, t, {}), TimedHull::Of(q_prev, t - 20'000'000, {}));
    a.Step(0.02, &q);
    b.Step(0.02, &q, nullptr, &motion);
    const BodyState &sa = a.bodies()[0], &sb = b.bodies()[0];
    ASSERT_EQ(sa.position, sb.position) << i;
    ASSERT_EQ(sa.velocity, sb.velocity) << i;
    if (sb.colliding && sb.last_response) {
      EXPECT_EQ(sb.last_response->hull_velocity.status, HullVelocityStatus::kMeasured);
      EXPECT_EQ(sb.last_response->hull_velocity.normal_speed, 0.0);
      ++measured;
    }
  }
  EXPECT_GT(measured, 0);
}

// A hull that appears around a resting ball (a hand entering the view) gives
// no velocity: the ball is pushed out, not thrown at the apparent speed.
TEST(BallSimulation, AHullThatAppearsDoesNotThrow) {
  const Eigen::Vector3d c0(0, 0, -1.0), d(1, 0, 0);
  const auto cams = RingCameras(4, 3.0, 1.6, c0, 640, 480, 0.9);
  const ShotFrame empty = ShootSphere(cams, 0, 25, [](double) { return SyntheticScene{}; });
  const ShotFrame cur = ShootSphere(cams, 1, 25, [&](double) { return SyntheticScene{{Shape::Sphere(c0, 0.1)}}; });
  const auto front = FirstHullPointAlong(*cur.query, c0 + d, -d, 1.0);
  ASSERT_TRUE(front);
  const SceneConfig cfg = RestingBall(*front + 0.02 * d);  // 3 cm inside
  BallSimulation sim(cfg);
  sim.Step(0, empty.query.get());
  const HullMotion motion(cur.timed, empty.timed);
  sim.Step(0.04, cur.query.get(), nullptr, &motion);
  const BodyState& s = sim.bodies()[0];
  ASSERT_TRUE(s.colliding && s.last_response);
  EXPECT_EQ(s.last_response->hull_velocity.status, HullVelocityStatus::kAppeared);
  EXPECT_EQ(s.velocity, Eigen::Vector3d::Zero());
  EXPECT_GT((s.position - c0).norm(), (*front - c0).norm() + 0.05 - 0.005);  // pushed out
}

}  // namespace
}  // namespace hullpipe
