// The particle stream against exact synthetic hulls: particles falling on a
// sphere (none left inside, some sliding off) and fast ones meeting a thin plate
// (none tunnelling through).
#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <fstream>

#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/scenes/ball.h"
#include "hullpipe/scenes/cloth.h"
#include "hullpipe/geometry/head_pose.h"
#include "hullpipe/scenes/particles.h"
#include "hullpipe/geometry/rigid3.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/scenes/virtual_scene.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {



TEST(Particles, NoneEndInsideASphereAndSomeSlideOff) {
  const Eigen::Vector3d centre(0, 0, -1.0);
  const VolumeQuery q(test::SphereViews(4, 320, 240, centre, 0.25), test::BigBox());
  ParticleConfig cfg;
  cfg.emitter = centre + Eigen::Vector3d(0.05, 0, -0.6);  // 60 cm above the top, a little off centre
  cfg.rate = 3000;
  cfg.max_particles = 3000;
  ParticleSystem ps(cfg, Eigen::Vector3d(0, 0, 9.81), true, 0.0);
  int hits = 0;
  for (int f = 0; f < 45; ++f) {
    const ParticleStepStats st = ps.Step(1.0 / 30, &q);
    hits += st.hits;
    EXPECT_EQ(st.left_inside, 0) << "frame " << f;
    for (const auto& x : ps.positions()) ASSERT_FALSE(q.Inside(x)) << "frame " << f;
  }
  EXPECT_GT(hits, 100);
  EXPECT_GT(ps.positions().size(), 1000u);
  // Some particles slid off the sphere and fell past its equator.
  int below = 0;
  for (const auto& x : ps.positions()) below += x.z() > centre.z() + 0.05;
  EXPECT_GT(below, 10);
}

TEST(Particles, FastParticlesDoNotTunnelThroughAThinPlate) {
  // A 1 cm plate; particles fall 1.2 m onto it at up to ~5 m/s, 16 cm per 1/30 s
  // frame: only the exact segment test stops them.
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Box(Eigen::Vector3d(0, 0, -1.0), Eigen::Vector3d(0.3, 0.3, 0.005)));
  const auto cams = RingCameras(4, 3.0, 1.0, Eigen::Vector3d(0, 0, -1.0), 640, 480, 0.9);
  std::vector<Camera> all = cams;
  all.push_back(test::LookAtCamera(9, Eigen::Vector3d(0.01, 0.02, -4.0), Eigen::Vector3d(0, 0, -1.0), 320, 240, 0.6));
  const VolumeQuery q = test::HullOf(scene, all);
  ParticleConfig cfg;
  cfg.emitter = Eigen::Vector3d(0, 0, -2.2);
  cfg.emitter_radius = 0.1;
  cfg.velocity = Eigen::Vector3d(0, 0, 1.0);
  cfg.restitution = 0.0;
  cfg.friction = 1.0;  // sand: stops where it lands
  cfg.max_substep = 1.0 / 30;
  ParticleSystem ps(cfg, Eigen::Vector3d(0, 0, 9.81), true, 0.0);
  for (int f = 0; f < 30; ++f) {
    const auto st = ps.Step(1.0 / 30, &q);
    EXPECT_EQ(st.left_inside, 0);
  }
  // Every particle that started over the plate is still above it.
  int through = 0, on_top = 0;
  for (const auto& x : ps.positions()) {
    if (std::abs(x.x()) < 0.25 && std::abs(x.y()) < 0.25) {
      through += x.z() > -1.0;
      on_top += x.z() < -1.0;
    }
  }
  EXPECT_EQ(through, 0);
  EXPECT_GT(on_top, 100);
}

}  // namespace
}  // namespace hullpipe
