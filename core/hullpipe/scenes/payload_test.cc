// The payload spacing task (paper §5.2): the spacing sweep's known answer on a
// synthetic motion, a part's clearance from an exact sphere hull, and the
// spacing changed while running.
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



TEST(PayloadTask, SpacingSweepFindsTheKnownAnswerOfASyntheticMotion) {
  // The paper's pipe (a 14 x 4 cm capsule) swings across the gap, reaching 1 + 4
  // + 6 = 11 cm from the PMT's face: the true pipe needs 11 cm.
  PayloadConfig cfg;
  double needed = 0;
  auto motion = ExamplePipeMotion(cfg, 0.06, 15, &needed);
  ASSERT_NEAR(needed, 0.11, 1e-12);
  // The motion goes through its CSV file format unchanged (9 significant digits).
  const std::string csv = (test::TempDir("motion") / "pipe.csv").string();
  SavePipeMotion(csv, motion);
  const auto loaded = LoadPipeMotion(csv);
  ASSERT_EQ(loaded.size(), motion.size());
  for (size_t k = 0; k < motion.size(); ++k) EXPECT_TRUE(loaded[k].q.isApprox(motion[k].q, 1e-8)) << k;
  motion = loaded;
  Eigen::Vector3d target = cfg.pmt_centre;
  target.y() += cfg.pmt_half.y() + 0.1;
  const auto cams = DomeCameras(8, 2.5, target, 320, 240, 0.9);
  std::vector<VolumeQuery> hulls;
  for (const auto& pose : motion) {
    SyntheticScene s;
    s.shapes.push_back(Shape::Capsule(pose.p, pose.q, pose.radius));
    hulls.push_back(test::HullOf(s, cams));
  }
  const SpacingSweepResult r = SweepSpacing(cfg, hulls, 0.08, 0.16, 0.02, 0.001);
  EXPECT_EQ(r.pmt_frames_colliding, 0);  // the motion keeps 1 cm off the PMT
  ASSERT_FALSE(std::isnan(r.smallest_free));
  // Exact maps mark a pixel whose centre ray hits the pipe, so the hull's side
  // differs from the pipe's by under one camera pixel's footprint at 2.5 m
  // (7.5 mm at 320 px over 0.9 rad), either way; plus the 1 mm bisection.
  EXPECT_NEAR(r.smallest_free, needed, 0.0085);
  // The table: colliding below the answer, free above it.
  for (const auto& row : r.rows) EXPECT_EQ(row.frames_colliding > 0, row.spacing < r.smallest_free) << row.spacing;
}

TEST(PayloadTask, ClearanceOfABoxFromASphereHull) {
  // A sphere (r 0.2) seen by 8 dome cameras; a box part 10 cm from it along +x.
  // The hull's side differs from the sphere's by under a pixel footprint (7.5 mm
  // at 2.5 m; exact maps sample pixel centres), either way.
  const Eigen::Vector3d c(0, 0, -1.0);
  SyntheticScene s;
  s.shapes.push_back(Shape::Sphere(c, 0.2));
  const VolumeQuery q = test::HullOf(s, DomeCameras(8, 2.5, c, 320, 240, 0.9));
  PayloadPart box;
  box.centre = c + Eigen::Vector3d(0.2 + 0.1 + 0.05, 0, 0);
  box.half_extents = Eigen::Vector3d(0.05, 0.1, 0.1);
  const ClearanceResult r = HullClearance(q, box, 0.15);
  EXPECT_TRUE(r.hull_near);
  EXPECT_FALSE(r.colliding);
  EXPECT_NEAR(r.distance, 0.1, 0.0075 + 0.0002);  // + half the finest grid's diagonal
  // Moved into the sphere: colliding, clearance 0.
  box.centre.x() -= 0.12;
  const ClearanceResult in = HullClearance(q, box, 0.15);
  EXPECT_TRUE(in.colliding);
  EXPECT_EQ(in.distance, 0.0);
}

TEST(PayloadTask, SpacingChangesWhileRunningAndBadValuesAreRefused) {
  SceneConfig cfg;
  cfg.Set(PayloadConfig{});
  VirtualScene scene(cfg);
  scene.SetSpacing(0.2);
  EXPECT_DOUBLE_EQ(scene.payload()->spacing, 0.2);
  EXPECT_DOUBLE_EQ(scene.config().Find<PayloadConfig>()->spacing, 0.2);  // one copy of the settings
  EXPECT_THROW(scene.SetSpacing(-1), std::invalid_argument);
  EXPECT_THROW(scene.SetSpacing(std::nan("")), std::invalid_argument);
  EXPECT_DOUBLE_EQ(scene.payload()->spacing, 0.2);  // unchanged
  const auto parts = scene.payload()->Parts();
  EXPECT_NEAR(parts[1].Bounds().min.y() - parts[0].Bounds().max.y(), 0.2, 1e-12);
  SceneConfig none;
  VirtualScene no_payload(none);
  EXPECT_THROW(no_payload.SetSpacing(0.2), std::invalid_argument);
}

}  // namespace
}  // namespace hullpipe
