// A `frame: stage` scene on rigs of either convention: the same file throws its
// ball at whoever is in the rig, under gravity along the rig's -up, onto the
// rig's floor (paper §4: the ball must reach the hull to collide with it).
#include <fstream>

#include <gtest/gtest.h>

#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/reconstruction/exact_hull.h"
#include "hullpipe/scenes/virtual_scene.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

// A sphere of 0.3 m, its centre 1 m above the floor (the plane through the
// origin), seen by 6 cameras 2 m above the floor, in a world whose up is `up`.
VolumeQuery SphereHull(const Eigen::Vector3d& up) {
  const Eigen::Vector3d centre = Eigen::Vector3d(0.5, -0.3, 0) + 1.0 * up;
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Sphere(centre, 0.3));
  std::vector<CameraMap> views;
  for (int i = 0; i < 6; ++i) {
    const double a = 6.2831853 * i / 6;
    const Camera c = LookingCamera(i + 1, Eigen::Vector3d(3 * std::cos(a), 3 * std::sin(a), 0) + 2.0 * up, centre,
                                   up, 320, 240, 1.2);
    views.push_back({c, RenderExactMap(c, scene)});
  }
  Aabb ws;
  ws.min = Eigen::Vector3d::Constant(-4);
  ws.max = Eigen::Vector3d::Constant(4);
  return VolumeQuery(views, ws);
}

SceneConfig StageScene(const std::filesystem::path& dir) {
  std::ofstream(dir / "scene.yaml") << "frame: stage\nballs:\n  - {radius: 0.1, start: [1.5, 0.2, 0.5], "
                                       "target: [0, 0, 0], flight_time: 0.5, rethrow_period: 0}\n";
  return LoadSceneConfig((dir / "scene.yaml").string());
}

TEST(StageScene, TheSameBallReachesTheHullOnAZUpAndAZDownRig) {
  const auto dir = test::TempDir("stage");
  for (const Eigen::Vector3d& up : {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 0, -1)}) {
    SCOPED_TRACE(up.z() > 0 ? "z up" : "z down");
    RigWorld world;
    world.up = up;
    world.floor = RigWorld::Floor::kPlane;
    world.floor_height = 0;
    SceneConfig cfg = StageScene(dir);
    cfg.PlaceInWorld(world);
    EXPECT_NEAR((cfg.gravity + 9.81 * up).norm(), 0, 1e-12);  // down is -up in either world
    EXPECT_DOUBLE_EQ(cfg.floor, 0.0);
    VirtualScene scene(cfg);
    const VolumeQuery hull = SphereHull(up);
    ASSERT_FALSE(hull.hull_box().empty());
    bool hit = false;
    for (int k = 0; k < 50 && !hit; ++k) {
      scene.Step(0.02, &hull);
      hit = scene.balls()->bodies()[0].colliding;
    }
    EXPECT_TRUE(hit) << "the ball never reached the hull";
    // Positive control of "reaches": the same scene in world coordinates (no
    // hull-relative placement) throws at the origin, far from the sphere.
    SceneConfig world_cfg = StageScene(dir);
    world_cfg.frame = SceneConfig::Frame::kWorld;
    VirtualScene miss(world_cfg);
    bool missed_hit = false;
    for (int k = 0; k < 50; ++k) {
      miss.Step(0.02, &hull);
      missed_hit |= miss.balls()->bodies()[0].colliding;
    }
    EXPECT_FALSE(missed_hit);
  }
}

TEST(StageScene, FloorUnderTheHullAndWaitingForAHull) {
  const auto dir = test::TempDir("stage_floor");
  RigWorld world;
  world.up = {0, 0, 1};
  world.floor = RigWorld::Floor::kUnderHull;
  SceneConfig cfg = StageScene(dir);
  cfg.PlaceInWorld(world);
  EXPECT_FALSE(cfg.has_floor);
  VirtualScene scene(cfg);
  scene.Step(0.1, nullptr);  // no hull: the ball waits, motionless
  EXPECT_EQ(scene.balls()->bodies()[0].velocity.norm(), 0.0);
  const VolumeQuery hull = SphereHull({0, 0, 1});
  scene.Step(0.02, &hull);
  EXPECT_TRUE(scene.balls()->config().has_floor);
  // g_hat = -z: the floor g_hat . x = floor is the hull's lowest z: at or
  // below the sphere's (0.7 m), within its box.
  EXPECT_NEAR(-scene.balls()->config().floor, -*HullExtentAlong(hull, {0, 0, -1}), 1e-12);
  EXPECT_LE(-scene.balls()->config().floor, 0.7 + 1e-9);
  EXPECT_GE(-scene.balls()->config().floor, hull.hull_box().min.z() - 1e-9);
  EXPECT_GT(scene.balls()->bodies()[0].velocity.norm(), 1.0);  // thrown
  // A stage scene refuses what stays in world coordinates, naming it.
  std::ofstream(dir / "bad.yaml") << "frame: stage\nfloor: 0\nballs: []\n";
  try {
    LoadSceneConfig((dir / "bad.yaml").string());
    FAIL();
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("'floor' with frame stage"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace hullpipe
