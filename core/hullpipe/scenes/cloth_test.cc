// The hybrid scenes against exact synthetic hulls: the cloth curtain
// pushed by a capsule (no vertex left inside), particles falling on a sphere (none
// left inside, none tunnelling through a thin plate), and a ball bouncing off a
// box face whose hull face is exact (outgoing direction against the exact
// reflection).
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



TEST(Cloth, HasThePapersTriangleCountAndHangsStill) {
  ClothConfig cfg;
  ClothSimulation cloth(cfg, Eigen::Vector3d(0, 0, 9.81));
  EXPECT_EQ(cloth.Mesh().triangles.size(), 720u);  // the paper's curtain
  const auto x0 = cloth.positions();
  for (int k = 0; k < 30; ++k) cloth.Step(1.0 / 30, nullptr);
  // Hanging at rest under gravity: it stretches only slightly (PBD constraints).
  double moved = 0;
  for (size_t i = 0; i < x0.size(); ++i) moved = std::max(moved, (cloth.positions()[i] - x0[i]).norm());
  EXPECT_LT(moved, 0.03);
  for (size_t i = 0; i < size_t(cfg.nx); ++i) EXPECT_EQ(cloth.positions()[i], x0[i]);  // pinned rod
}

TEST(Cloth, ACapsulePushedThroughLeavesNoVertexInsideTheHull) {
  // A forearm-like capsule (r 5 cm) moves along +x through a curtain hanging in
  // the plane x = 0; 4 dome cameras see it with exact maps.
  ClothConfig cfg;
  cfg.rod_a = Eigen::Vector3d(0, -0.4, -1.6);
  cfg.rod_b = Eigen::Vector3d(0, 0.4, -1.6);
  cfg.length = 0.8;
  const Eigen::Vector3d target(0, 0, -1.2);
  const auto cams = DomeCameras(4, 3.0, target, 320, 240, 0.9);
  ClothSimulation cloth(cfg, Eigen::Vector3d(0, 0, 9.81));
  int moved = 0;
  for (int f = 0; f < 36; ++f) {
    const double t = f / 30.0;
    const Eigen::Vector3d tip(-0.3 + 0.6 * t, 0.02, -1.15);
    SyntheticScene scene;
    scene.shapes.push_back(Shape::Capsule(tip - Eigen::Vector3d(0.4, 0, 0), tip, 0.05));
    const VolumeQuery q = test::HullOf(scene, cams);
    const ClothStepStats st = cloth.Step(1.0 / 30, &q);
    moved += st.vertices_moved;
    EXPECT_EQ(st.vertices_left_inside, 0) << "frame " << f;
    for (size_t i = 0; i < cloth.positions().size(); ++i)
      if (!cloth.pinned(i)) {
        ASSERT_FALSE(q.Inside(cloth.positions()[i])) << "vertex " << i << " frame " << f;
      }
  }
  EXPECT_GT(moved, 0);
  // The curtain was pushed aside: some vertex is well past the plane x = 0.
  double max_x = -1;
  for (const auto& p : cloth.positions()) max_x = std::max(max_x, p.x());
  EXPECT_GT(max_x, 0.1);
}

}  // namespace
}  // namespace hullpipe
