// The hybrid scenes of issue 6 against exact synthetic hulls: the cloth curtain
// pushed by a capsule (no vertex left inside), particles falling on a sphere (none
// left inside, none tunnelling through a thin plate), and a ball bouncing off a
// box face whose hull face is exact (outgoing direction against the exact
// reflection).
#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <fstream>

#include "hullpipe/ball_scene.h"
#include "hullpipe/cloth.h"
#include "hullpipe/head_pose.h"
#include "hullpipe/particles.h"
#include "hullpipe/rigid3.h"
#include "hullpipe/synthetic.h"
#include "hullpipe/virtual_scene.h"
#include "test_util.h"

namespace hullpipe {
namespace {

Camera LookAtCamera(int id, const Eigen::Vector3d& eye, const Eigen::Vector3d& target, int w, int h, double hfov) {
  return LookingCamera(id, eye, target, Eigen::Vector3d(0, 0, -1), w, h, hfov);
}

VolumeQuery HullOf(const SyntheticScene& scene, const std::vector<Camera>& cams) {
  std::vector<CameraMap> views;
  for (const auto& c : cams) views.push_back({c, RenderExactMap(c, scene)});
  return VolumeQuery(views, test::BigBox());
}

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
    const VolumeQuery q = HullOf(scene, cams);
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
  all.push_back(LookAtCamera(9, Eigen::Vector3d(0.01, 0.02, -4.0), Eigen::Vector3d(0, 0, -1.0), 320, 240, 0.6));
  const VolumeQuery q = HullOf(scene, all);
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

TEST(BallAndBlocks, BounceOffABoxFaceIsTheExactReflection) {
  // A real block: an axis-aligned box. Two cameras lie in the plane of its face
  // x = +0.2, so that face is exactly a face of the visual hull (its silhouette
  // edge back-projects into that plane); a third looks from above.
  const Eigen::Vector3d c(0, 0, -1.0);
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Box(c, Eigen::Vector3d(0.2, 0.3, 0.3)));
  const std::vector<Camera> cams = {
      LookAtCamera(1, c + Eigen::Vector3d(0.2, -3.0, 0.1), c + Eigen::Vector3d(0.2, 0, 0), 640, 480, 0.5),
      LookAtCamera(2, c + Eigen::Vector3d(0.2, 3.0, -0.1), c + Eigen::Vector3d(0.2, 0, 0), 640, 480, 0.5),
      LookAtCamera(3, c + Eigen::Vector3d(1.5, 0.3, -2.5), c, 640, 480, 0.6)};
  const VolumeQuery q = HullOf(scene, cams);
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
    hulls.push_back(HullOf(s, cams));
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
  const VolumeQuery q = HullOf(s, DomeCameras(8, 2.5, c, 320, 240, 0.9));
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
  cfg.balls.clear();
  cfg.payload = PayloadConfig{};
  VirtualScene scene(cfg);
  scene.SetSpacing(0.2);
  EXPECT_DOUBLE_EQ(scene.payload()->spacing, 0.2);
  EXPECT_DOUBLE_EQ(scene.config().payload->spacing, 0.2);  // one copy of the settings
  EXPECT_THROW(scene.SetSpacing(-1), std::invalid_argument);
  EXPECT_THROW(scene.SetSpacing(std::nan("")), std::invalid_argument);
  EXPECT_DOUBLE_EQ(scene.payload()->spacing, 0.2);  // unchanged
  const auto parts = scene.payload()->Parts();
  EXPECT_NEAR(parts[1].Bounds().min.y() - parts[0].Bounds().max.y(), 0.2, 1e-12);
  SceneConfig none;
  VirtualScene no_payload(none);
  EXPECT_THROW(no_payload.SetSpacing(0.2), std::invalid_argument);
}

TEST(SceneFiles, EveryShippedSceneLoads) {
  for (const char* name : {"ball", "ball_blocks", "curtain", "particles", "payload"}) {
    const std::string path = std::string(HULLPIPE_SOURCE_DIR) + "/scenes/" + name + ".yaml";
    EXPECT_NO_THROW(VirtualScene(LoadSceneConfig(path))) << path;
  }
}

}  // namespace
}  // namespace hullpipe

namespace hullpipe {
namespace {

TEST(HeadPose, FileTrackInterpolatesAndRejectsBadFiles) {
  const auto dir = test::TempDir("pose");
  const std::string path = (dir / "poses.csv").string();
  {
    std::ofstream f(path);
    // A quarter turn about world z between t = 0 and t = 2, moving 1 m along x.
    f << "t,x,y,z,qw,qx,qy,qz\n0,0,0,-1,1,0,0,0\n2,1,0,-1," << std::cos(M_PI / 4) << ",0,0," << std::sin(M_PI / 4)
      << "\n";
  }
  const PoseTrack track = LoadPoseTrack(path);
  ASSERT_EQ(track.size(), 2u);
  const Rigid3d mid = track.At(1.0);
  EXPECT_TRUE(mid.translation.isApprox(Eigen::Vector3d(0.5, 0, -1), 1e-12));
  EXPECT_TRUE(mid.rotation.isApprox(Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitZ()).toRotationMatrix(), 1e-9));
  EXPECT_TRUE(track.At(-5).translation.isApprox(Eigen::Vector3d(0, 0, -1)));  // held at the ends
  EXPECT_TRUE(track.At(9).translation.isApprox(Eigen::Vector3d(1, 0, -1)));
  auto bad = [&](const std::string& body) {
    std::ofstream(path) << body;
    return [&] { LoadPoseTrack(path); };
  };
  EXPECT_THROW(bad("t,x\n0,1,2\n")(), std::runtime_error);                  // columns
  EXPECT_THROW(bad("0,0,0,0,0,0,0,0\n")(), std::runtime_error);             // zero quaternion
  EXPECT_THROW(bad("0,0,0,0,1,0,0,0\n0,1,0,0,1,0,0,0\n")(), std::runtime_error);  // same time
  EXPECT_THROW(bad("0,0,0,0,1,0,0,0\n1,a,0,0,1,0,0,0\n")(), std::runtime_error);  // not a number
  EXPECT_THROW(LoadPoseTrack((dir / "missing.csv").string()), std::runtime_error);
}

}  // namespace
}  // namespace hullpipe
