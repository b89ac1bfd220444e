#include "hullpipe/scenes/model_scene.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include <Eigen/Geometry>

#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/scenes/virtual_scene.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

namespace fs = std::filesystem;

const std::string kEngine = "/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";

SceneConfig Load(const fs::path& dir, const std::string& yaml) {
  const fs::path p = dir / "scene.yaml";
  std::ofstream(p) << yaml;
  return LoadSceneConfig(p.string());
}

std::string LoadError(const fs::path& dir, const std::string& yaml) {
  try {
    Load(dir, yaml);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

// The world triangles of a scene's first model, corners sorted, rounded to 1 µm.
std::multiset<std::vector<long>> WorldTriangles(const SceneConfig& cfg) {
  const auto* m = cfg.Find<ModelsConfig>();
  std::multiset<std::vector<long>> out;
  for (const ScenePart& p : PlaceModel(*m->models[0].imported, m->models[0], -cfg.gravity.normalized())) {
    for (const auto& t : p.mesh.triangles) {
      std::vector<std::vector<long>> c;
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3d& v = p.mesh.vertices[size_t(t[k])];
        c.push_back({std::lround(v.x() * 1e6), std::lround(v.y() * 1e6), std::lround(v.z() * 1e6)});
      }
      std::sort(c.begin(), c.end());
      out.insert({c[0][0], c[0][1], c[0][2], c[1][0], c[1][1], c[1][2], c[2][0], c[2][1], c[2][2]});
    }
  }
  return out;
}

// One triangle, (0,0,0) (0.2,0,0) (0,0.1,0) metres, in each format with its own
// units and up axis: placed, all give the same world triangle.
TEST(ModelScene, UnitsUpAxisAndPoseGiveTheSameWorldTriangles) {
  const fs::path dir = test::TempDir("model_scene_units");
  // OBJ in millimetres, y up: the model's "up" is y, the world's is -z.
  std::ofstream(dir / "t.obj") << "o t\nv 0 0 0\nv 200 0 0\nv 0 0 -100\nf 1 2 3\n";
  // STL in inches, z up (STL's default here).
  const double in = 1 / 0.0254;
  std::ofstream(dir / "t.stl") << "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex " << 0.2 * in
                               << " 0 0\nvertex 0 0 " << -0.1 * in << "\nendloop\nendfacet\nendsolid t\n";
  const std::string head = "gravity: [0, 0, 9.81]\nballs: []\nmodels:\n";
  // World up is -z. OBJ: file y -> world -z by the shortest turn (about x), which
  // takes file z to world y: file (0, 0, -100 mm) -> world (0, -0.1, 0).
  const auto obj = WorldTriangles(Load(dir, head + "  - {file: t.obj, units: mm, up: +y, position: [1, 2, 3]}\n"));
  // The same triangle in inches in an STL file, told its up is y (STL's default is z).
  const auto stl = WorldTriangles(Load(dir, head + "  - {file: t.stl, units: in, up: +y, position: [1, 2, 3]}\n"));
  ASSERT_EQ(obj.size(), 1u);
  const std::vector<long> want{1000000, 1900000, 3000000, 1000000, 2000000, 3000000, 1200000, 2000000, 3000000};
  EXPECT_EQ(*obj.begin(), want);
  EXPECT_EQ(stl, obj);
  // yaw_deg turns about the world's up (-z): 90 degrees takes (0.2, 0, 0) off the x axis.
  EXPECT_NE(
      WorldTriangles(Load(dir, head + "  - {file: t.obj, units: mm, up: +y, yaw_deg: 90, position: [1, 2, 3]}\n")),
      obj);
  // scale: is units' other spelling.
  EXPECT_EQ(WorldTriangles(Load(dir, head + "  - {file: t.obj, scale: 0.001, up: +y, position: [1, 2, 3]}\n")), obj);
  // anchor centre: the model box's centre goes to position.
  const auto centre =
      WorldTriangles(Load(dir, head + "  - {file: t.obj, units: mm, up: +y, anchor: centre, position: [0, 0, 0]}\n"));
  const std::vector<long> centred{-100000, -50000, 0, -100000, 50000, 0, 100000, 50000, 0};
  EXPECT_EQ(*centre.begin(), centred);
}

TEST(ModelScene, BadEntriesNameTheKey) {
  const fs::path dir = test::TempDir("model_scene_bad");
  std::ofstream(dir / "t.obj") << "o t\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  const std::string head = "balls: []\nmodels:\n";
  EXPECT_NE(LoadError(dir, head + "  - {file: t.obj}\n").find("carries no units"), std::string::npos);
  EXPECT_NE(LoadError(dir, head + "  - {file: t.obj, units: furlong}\n").find("models[0].units"), std::string::npos);
  EXPECT_NE(LoadError(dir, head + "  - {file: t.obj, units: m, scale: 2}\n").find("not both"), std::string::npos);
  EXPECT_NE(LoadError(dir, head + "  - {file: t.obj, units: m, up: w}\n").find("'models[0].up' must be one of"),
            std::string::npos);
  EXPECT_NE(LoadError(dir, head + "  - {file: t.obj, units: m, anchor: top}\n")
                .find("'models[0].anchor' must be origin, centre or bottom, not top"),
            std::string::npos);
  EXPECT_NE(LoadError(dir, head + "  - {file: t.obj, unit: m}\n").find("unknown key 'models[0].unit'"),
            std::string::npos);
  EXPECT_NE(LoadError(dir, head + "  - {file: t.obj, units: m, motion: rolling}\n").find("models[0].motion"),
            std::string::npos);
  EXPECT_NE(LoadError(dir, head + "  - {file: t.obj, units: m, motion: dynamic, restitution: 2}\n").find("restitution"),
            std::string::npos);
  EXPECT_NE(LoadError(dir, head + "  - {file: t.obj, units: m, colour: red}\n").find("unknown key 'models[0].colour'"),
            std::string::npos);
  EXPECT_NE(LoadError(dir, head + "  - {file: t.obj, units: m, warn_distance: 0.2, max_clearance: 0.1}\n")
                .find("max_clearance"),
            std::string::npos);
  EXPECT_NE(LoadError(dir, head + "  - {file: absent.obj, units: m}\n").find("absent.obj"), std::string::npos);
  EXPECT_NE(LoadError(dir, "balls: []\nmodels: {file: t.obj}\n").find("list of model entries"), std::string::npos);
  // Two models whose ids overlap.
  EXPECT_NE(
      LoadError(dir, head + "  - {file: t.obj, units: m, first_id: 5}\n  - {file: t.obj, units: m, first_id: 5}\n")
          .find("overlap"),
      std::string::npos);
  // Read without importing (render_node): keys only, the file is not opened.
  const fs::path p = dir / "noimport.yaml";
  std::ofstream(p) << head << "  - {file: absent.obj, units: m}\n";
  EXPECT_NO_THROW(LoadSceneConfig(p.string(), SceneLoadOptions{false}));
}

// Scales and positions that put a model's vertices beyond any rig (a scale of
// 1e308 once gave non-finite vertices: sim published them, render refused them
// and drew nothing, every node exited 0), and models of more parts than the
// cap (a 4-MB glTF of 200,000 one-triangle nodes cost sim 4 GB and 19 s a
// step): refused at load, naming the key or the cap. The controls load.
TEST(ModelScene, AbsurdScalesAndPartFloodsAreRefusedNamingTheKey) {
  const fs::path dir = test::TempDir("model_scene_absurd");
  std::ofstream(dir / "t.obj") << "o t\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  std::ofstream(dir / "far.obj") << "o t\nv 0 0 0\nv 1e38 0 0\nv 0 1e38 0\nf 1 2 3\n";
  const std::string head = "balls: []\nmodels:\n";
  for (const char* scale : {"1e308", "1e30", "0", "-1", "1e-9", ".nan"})
    EXPECT_NE(
        LoadError(dir, head + "  - {file: t.obj, scale: " + scale + "}\n").find("models[0]': models: scale must be in"),
        std::string::npos)
        << scale;
  EXPECT_NE(LoadError(dir, head + "  - {file: t.obj, units: m, position: [1e300, 0, 0]}\n").find("position"),
            std::string::npos);
  const std::string far = LoadError(dir, head + "  - {file: far.obj, units: m}\n");
  EXPECT_NE(far.find("models[0].scale'"), std::string::npos) << far;
  EXPECT_NE(far.find("over 10000 m"), std::string::npos) << far;
  // 1 km per unit, a 1-unit model: 2.8 km at most from the origin.
  EXPECT_EQ(LoadError(dir, head + "  - {file: t.obj, scale: 1000}\n"), "");
  EXPECT_EQ(LoadError(dir, head + "  - {file: far.obj, scale: 1e-35}\n").find("over 10000 m"), std::string::npos);
  // Parts: one over the cap in one file, and the cap reached by two files.
  const auto parts = [&](const std::string& name, int n) {
    std::ofstream o(dir / name);
    for (int k = 0; k < n; ++k)
      o << "o p" << k << "\nv " << k << " 0 0\nv " << k + 0.5 << " 0 0\nv " << k << " 0.5 0\nf " << 3 * k + 1 << ' '
        << 3 * k + 2 << ' ' << 3 * k + 3 << '\n';
  };
  parts("flood.obj", int(kMaxSceneModelParts) + 1);
  parts("half.obj", int(kMaxSceneModelParts) / 2 + 1);
  const std::string flood = LoadError(dir, head + "  - {file: flood.obj, scale: 0.001}\n");
  EXPECT_NE(flood.find("more than 4096 parts"), std::string::npos) << flood;
  EXPECT_NE(flood.find("flood.obj"), std::string::npos) << flood;
  EXPECT_EQ(LoadError(dir, head + "  - {file: half.obj, scale: 0.001}\n"), "");
  const std::string two =
      LoadError(dir, head + "  - {file: half.obj, scale: 0.001}\n  - {file: half.obj, scale: 0.001, first_id: 9000}\n");
  EXPECT_NE(two.find("more than 2047 parts"), std::string::npos) << two;
}

// The element against the synthetic figure: the part the forearm crosses is
// red, one a few centimetres beyond the hand amber, a far one clear; its
// collision points equal brute force (DetectCollisions of the part's world mesh).
TEST(ModelScene, PartsTurnRedAndAmberAsTheHullComes) {
  const fs::path dir = test::TempDir("model_scene_step");
  // Three boxes as three OBJ objects (metres): where the figure's right forearm
  // waves (1.5 m up), 3 cm beyond the hand's reach, and 1 m away.
  {
    std::ofstream o(dir / "parts.obj");
    test::WriteObjCube(o, "crossed", {0.55, 0.0, -1.5}, 0.1, 0);
    test::WriteObjCube(o, "beyond", {0.82, 0.0, -1.55}, 0.03, 8);
    test::WriteObjCube(o, "far", {-1.0, 1.0, -0.5}, 0.05, 16);
  }
  const SceneConfig cfg =
      Load(dir, "gravity: [0, 0, 9.81]\nballs: []\nmodels:\n  - {file: parts.obj, units: m, up: -z, "
                "warn_distance: 0.06, max_clearance: 0.1}\n");
  VirtualScene scene(cfg);
  const auto cams = RingCameras(4, 3.0, 1.8, Eigen::Vector3d(0.2, 0, -1.0), 320, 240, 1.0);
  const auto* models = cfg.Find<ModelsConfig>();
  const auto parts = PlaceModel(*models->models[0].imported, models->models[0], -cfg.gravity.normalized());
  ASSERT_EQ(parts.size(), 3u);
  int red = 0, amber = 0;
  for (int f = 0; f < 8; ++f) {
    const VolumeQuery q = test::HullOf(AnimatedFigure(0.5 * f), cams);
    scene.Step(0.5, &q);
    const ElementOutput out = scene.Output(0.5 * f, uint64_t(f + 1));
    ASSERT_EQ(out.model_states.size(), 1u);
    const ModelStateSample& st = out.model_states[0];
    ASSERT_EQ(st.parts.size(), 3u);
    EXPECT_EQ(st.parts[2].contact, kPartClear);
    EXPECT_NEAR(st.parts[2].clearance, 0.1, 1e-12);  // nothing within range
    red += st.parts[0].contact == kPartColliding;
    amber += st.parts[1].contact == kPartNear;
    if (st.parts[1].contact == kPartNear) {
      EXPECT_LT(st.parts[1].clearance, 0.06);
    }
    // Reports: one per colliding part, equal to brute force.
    for (const auto& r : out.reports) {
      const size_t k = r.object_id - 1000;
      const CollisionResult brute = DetectCollisions(q, parts[k].mesh, TriangleQueryOptions{0.004, 0, 32});
      EXPECT_EQ(r.collision_points, brute.collision_points);
    }
    EXPECT_EQ(st.triangles, 36u);
  }
  EXPECT_GE(red, 4);
  EXPECT_GE(amber, 1);
}

// The world position of a part's body-frame point after the last step.
Eigen::Vector3d PartPoint(const PartStateSample& s, const Eigen::Vector3d& body) {
  const Eigen::Quaterniond q(s.orientation[0], s.orientation[1], s.orientation[2], s.orientation[3]);
  return q * body + s.position;
}

// motion: dynamic. The world is the Utrecht rig's (z down, floor z = 0). A
// cube (10 cm) dropped from 0.5 m comes to rest on the floor, its lowest face
// on it; the same cube static stays where it was put (the control of "falls").
TEST(ModelScene, DynamicPartsFallAndRestOnTheFloor) {
  const fs::path dir = test::TempDir("model_scene_dynamic_floor");
  {
    std::ofstream o(dir / "cube.obj");
    test::WriteObjCube(o, "cube", {0, 0, 0}, 0.05, 0);
  }
  for (const std::string motion : {"dynamic", "static"}) {
    SCOPED_TRACE(motion);
    const SceneConfig cfg = Load(dir, "gravity: [0, 0, 9.81]\nfloor: 0\nballs: []\nmodels:\n  - {file: cube.obj, "
                                      "units: m, up: -z, anchor: bottom, position: [0.3, 0.2, -0.5], motion: " +
                                          motion + "}\n");
    VirtualScene scene(cfg);
    ElementOutput out;
    for (int f = 0; f < 75; ++f) {  // 3 s at 25 fps, no hull
      scene.Step(0.04, nullptr);
      out = scene.Output(0.04 * f, uint64_t(f + 1));
    }
    ASSERT_EQ(out.model_states.size(), 1u);
    const PartStateSample& s = out.model_states[0].parts[0];
    // The body frame is the file's: the cube's bottom face centre is (0, 0, 0.05).
    const Eigen::Vector3d bottom = PartPoint(s, {0, 0, 0.05});
    if (motion == "dynamic") {
      EXPECT_NEAR(bottom.z(), 0.0, 1e-3);  // on the floor: within one substep's fall at rest (g h^2)
      EXPECT_NEAR(bottom.x(), 0.3, 1e-9);  // straight down
      EXPECT_NEAR(bottom.y(), 0.2, 1e-9);
    } else {
      EXPECT_NEAR((bottom - Eigen::Vector3d(0.3, 0.2, -0.5)).norm(), 0.0, 1e-9);
    }
  }
}

// The hull pushes a dynamic part with §4.2's response, as it does a ball: a
// cube dropped 0.3 m onto the flat top of a box (exact maps of 6 cameras level
// with that top, so the hull's top is the box's to a pixel) touches it, is
// reported colliding with a response whose N_hull points up, is never inside
// the hull at the end of a step, and bounces to e^2 times its drop onto the
// hull's surface (restitution e = 0.5: the rebound of a body whose speed v is
// reflected to e v at the surface). Without the hull it falls into it (the
// control of "never inside").
TEST(ModelScene, TheHullBouncesADynamicPart) {
  const fs::path dir = test::TempDir("model_scene_dynamic_hull");
  {
    std::ofstream o(dir / "cube.obj");
    test::WriteObjCube(o, "cube", {0, 0, 0}, 0.05, 0);
  }
  const Eigen::Vector3d centre(0.1, -0.1, -1.0);
  const double top = centre.z() - 0.3, start = top - 0.3;  // z down: the box's top, z = -1.3
  SyntheticScene block;
  block.shapes.push_back(Shape::Box(centre, Eigen::Vector3d::Constant(0.3)));
  const VolumeQuery hull = test::HullOf(block, RingCameras(6, 3.0, -top, centre, 320, 240, 1.0));
  // Substeps of 1 ms: the integrator (semi-implicit Euler) then loses v h / 2
  // = 0.6 mm of the rebound's height, and the cube sinks at most 2.5 mm (its
  // fall in one substep) before the response.
  std::ostringstream yaml;
  yaml << "gravity: [0, 0, 9.81]\nfloor: 0\nmax_substep: 0.001\nballs: []\nmodels:\n  - {file: cube.obj, units: m, "
          "up: -z, anchor: bottom, motion: dynamic, restitution: 0.5, warn_distance: 0, max_pixel_size: 0.002, "
          "position: ["
       << centre.x() << ", " << centre.y() << ", " << start << "]}\n";
  const SceneConfig cfg = Load(dir, yaml.str());
  for (const bool with_hull : {true, false}) {
    SCOPED_TRACE(with_hull ? "hull" : "no hull");
    VirtualScene scene(cfg);
    int hits = 0, responses = 0, inside = 0;
    double surface = 0, apex = 1e9;  // z of the hull's surface at the first contact; least z after it
    for (int f = 0; f < 40; ++f) {  // 0.8 s at 50 fps
      scene.Step(0.02, with_hull ? &hull : nullptr);
      const ElementOutput out = scene.Output(0.02 * f, uint64_t(f + 1));
      const PartStateSample& s = out.model_states[0].parts[0];
      const Eigen::Vector3d bottom = PartPoint(s, {0, 0, 0.05});  // the bottom face's centre
      inside += hull.Inside(bottom);
      if (s.contact == kPartColliding) {
        ASSERT_EQ(out.reports.size(), 1u);
        const CollisionReportSample& rep = out.reports[0];
        EXPECT_EQ(rep.object_id, 1000u);
        if (rep.has_response) {
          if (responses++ == 0) surface = rep.cp_hull.z();
          EXPECT_GT(rep.n_hull.dot(Eigen::Vector3d(0, 0, -1)), 0.99);  // up, on the box's top
        }
        ++hits;
      }
      if (responses > 0 && f < 30) apex = std::min(apex, bottom.z());  // the first rebound's top
    }
    if (with_hull) {
      EXPECT_GT(hits, 0);
      ASSERT_GT(responses, 0);
      EXPECT_NEAR(surface, top, 0.006);  // the hull's top: the box's to a pixel (10 mm at 3 m)
      EXPECT_EQ(inside, 0);
      // e^2 x the drop, within 2 mm: the 2.5 mm the cube may sink before the
      // response (0.6 mm of height back), the integrator's 0.6 mm, the apex
      // sampled every 20 ms (0.5 mm).
      EXPECT_NEAR(surface - apex, 0.25 * (surface - start), 0.002);
    } else {
      EXPECT_EQ(hits, 0);
      EXPECT_GT(inside, 0);
    }
  }
}

// A dynamic part is thrown by a moving hull as a ball is (docs/collision.md,
// "Hull velocity"): a cube at rest (no gravity) 1 cm above a box that rises at
// 1 m/s, filmed at 50 fps by six 640x480 cameras with exact maps. Its report
// carries the hull's measured normal speed w, and it leaves at (1 + e) w;
// without the hull's motion it is only pushed out and stays at rest.
TEST(ModelScene, AMovingHullThrowsADynamicPart) {
  const fs::path dir = test::TempDir("model_scene_dynamic_bat");
  {
    std::ofstream o(dir / "cube.obj");
    test::WriteObjCube(o, "cube", {0, 0, 0}, 0.05, 0);
  }
  const Eigen::Vector3d centre(0.1, -0.1, -1.0), up(0, 0, -1);
  const double speed = 1.0, fps = 50, top = centre.z() - 0.3;  // z down: the box's top at rest
  const auto cams = RingCameras(6, 3.0, -top, centre, 640, 480, 1.0);
  auto hull_at = [&](int k) {
    SyntheticScene block;
    block.shapes.push_back(Shape::Box(centre + speed * (k / fps) * up, Eigen::Vector3d::Constant(0.3)));
    return std::make_unique<VolumeQuery>(test::HullOf(block, cams));
  };
  std::ostringstream yaml;
  yaml << "gravity: [0, 0, 0]\nfloor: null\nmax_substep: 0.001\nballs: []\nmodels:\n  - {file: cube.obj, units: m, "
          "up: -z, anchor: bottom, motion: dynamic, restitution: 0.5, warn_distance: 0, max_pixel_size: 0.002, "
          "position: ["
       << centre.x() << ", " << centre.y() << ", " << top - 0.01 << "]}\n";
  const SceneConfig cfg = Load(dir, yaml.str());
  for (const bool moving : {true, false}) {
    SCOPED_TRACE(moving ? "with the hull's motion" : "without");
    VirtualScene scene(cfg);
    std::unique_ptr<VolumeQuery> prev = hull_at(0);
    scene.Step(0, prev.get());
    double w = 0;
    std::vector<double> bottom_z;
    for (int k = 1; k <= 6; ++k) {
      std::unique_ptr<VolumeQuery> cur = hull_at(k);
      const HullMotion motion(TimedHull::Of(*cur, int64_t(k) * 20'000'000, {}),
                              TimedHull::Of(*prev, int64_t(k - 1) * 20'000'000, {}));
      scene.Step(1 / fps, cur.get(), nullptr, moving ? &motion : nullptr);
      const ElementOutput out = scene.Output(k / fps, uint64_t(k));
      for (const auto& r : out.reports)
        if (r.has_response && r.hull_velocity_status == uint8_t(HullVelocityStatus::kMeasured)) w = r.hull_normal_speed;
      bottom_z.push_back(PartPoint(out.model_states[0].parts[0], {0, 0, 0.05}).z());
      prev = std::move(cur);
    }
    const double v_after = -(bottom_z[5] - bottom_z[3]) / (2 / fps);  // upward, m/s
    if (moving) {
      // w: 1.42 px of quantization (5 mm at 3 m) over 20 ms, plus 5%.
      EXPECT_NEAR(w, speed, 0.41);
      EXPECT_NEAR(v_after, 1.5 * w, 0.02) << "(1 + e) w";
    } else {
      EXPECT_EQ(w, 0.0);
      // Only pushed out, frame by frame: it rides on the rising top (a little
      // faster: the 1 mm clearance each push, and a top that grows as it rises
      // above the cameras' level), never thrown ahead of it.
      EXPECT_NEAR(v_after, speed, 0.15);
      EXPECT_LT(v_after, 1.25 * speed);
    }
  }
}

// frame: stage. The same scene file puts the model at the same place relative
// to the stage (StageFrame: on the floor below the workspace's centre, z up)
// on a z-up and a z-down rig; a stage scene still refuses world-only kinds.
TEST(ModelScene, AStageScenePlacesTheModelOnAnyRig) {
  const fs::path dir = test::TempDir("model_scene_stage");
  std::ofstream(dir / "t.obj") << "o t\nv 0 0 0\nv 0.2 0 0\nv 0 0.1 0.05\nf 1 2 3\n";
  const std::string yaml = "frame: stage\nballs: []\nmodels:\n  - {file: t.obj, units: m, up: +z, yaw_deg: 30, "
                           "position: [0.3, -0.2, 0.1]}\n";
  std::vector<std::vector<Eigen::Vector3d>> in_stage;
  for (const double up_z : {1.0, -1.0}) {
    RigWorld world;
    world.up = {0, 0, up_z};
    world.floor = RigWorld::Floor::kPlane;
    world.floor_height = 0.25;
    Aabb ws;
    ws.min = Eigen::Vector3d(-1, 2, -1);
    ws.max = Eigen::Vector3d(1, 4, 1);
    SceneConfig cfg = Load(dir, yaml);
    cfg.PlaceInWorld(world, ws);
    const Rigid3d world_from_stage = StageFrame(world, ws);
    const auto* m = cfg.Find<ModelsConfig>();
    ASSERT_NE(m, nullptr);
    const auto parts = PlaceModel(*m->models[0].imported, m->models[0], -cfg.gravity.normalized());
    ASSERT_EQ(parts.size(), 1u);
    std::vector<Eigen::Vector3d> v;
    for (const auto& p : parts[0].mesh.vertices) v.push_back(world_from_stage.Inverse() * p);
    in_stage.push_back(v);
    // The file's origin at the stage position: 0.1 m above the floor.
    EXPECT_NEAR(world.up.dot(parts[0].mesh.vertices[0]), 0.25 + 0.1, 1e-12);
    VirtualScene scene(cfg);  // runs
    scene.Step(0.04, nullptr);
  }
  ASSERT_EQ(in_stage[0].size(), 3u);
  // Tolerances: the file's vertices are single precision (0.2 m to 3e-9 m).
  for (size_t k = 0; k < 3; ++k) EXPECT_NEAR((in_stage[0][k] - in_stage[1][k]).norm(), 0, 1e-7);
  EXPECT_NEAR((in_stage[0][0] - Eigen::Vector3d(0.3, -0.2, 0.1)).norm(), 0, 1e-7);
  // yaw 30 degrees about the stage's z from its x axis: (0.2, 0, 0) -> 0.2 (cos 30, sin 30, 0).
  EXPECT_NEAR((in_stage[0][1] - Eigen::Vector3d(0.3 + 0.2 * std::cos(M_PI / 6), -0.2 + 0.2 * std::sin(M_PI / 6), 0.1))
                  .norm(),
              0, 1e-7);
  EXPECT_NE(LoadError(dir, "frame: stage\nballs: []\nparticles: {emitter: [0, 0, 1], velocity: [0, 0, 1]}\n")
                .find("places balls and models only"),
            std::string::npos);
}

// A dynamic model's parts are queried every substep: over the cap, refused naming it.
TEST(ModelScene, ADynamicModelOverTheCapIsRefused) {
  auto big = std::make_shared<ImportedModel>();
  big->path = "big.stl";
  big->parts.resize(1);
  big->parts[0].vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  big->parts[0].triangles.assign(size_t(kMaxDynamicModelTriangles) + 1, Eigen::Vector3i(0, 1, 2));
  ModelEntry e;
  e.file = "big.stl";
  e.imported = big;
  EXPECT_NO_THROW(e.Check());  // static: fine
  e.motion = ModelEntry::Motion::kDynamic;
  try {
    e.Check();
    FAIL();
  } catch (const std::invalid_argument& x) {
    EXPECT_NE(std::string(x.what()).find("cap of 200000"), std::string::npos) << x.what();
  }
}

TEST(ModelScene, TheEngineSceneLoadsAtRealSize) {
  if (!fs::exists(kEngine)) GTEST_SKIP() << kEngine << " missing: scripts/setup.sh installs assimp-testmodels";
  const SceneConfig cfg = LoadSceneConfig(std::string(HULLPIPE_SOURCE_DIR) + "/scenes/engine.yaml");
  const auto* m = cfg.Find<ModelsConfig>();
  ASSERT_NE(m, nullptr);
  Aabb box;
  for (const ScenePart& p : PlaceModel(*m->models[0].imported, m->models[0], -cfg.gravity.normalized()))
    box.Extend(p.mesh.Bounds().min), box.Extend(p.mesh.Bounds().max);
  // 743 x 273 x 268 mm (file x, y, z): its length along world x, its up
  // (file +y, 273 mm) along world -z.
  const Eigen::Vector3d size = box.max - box.min;
  EXPECT_NEAR(size.x(), 0.7434, 1e-3);
  EXPECT_NEAR(size.y(), 0.268, 1e-3);
  EXPECT_NEAR(size.z(), 0.2730, 1e-3);
  EXPECT_NEAR(box.max.z(), -0.42, 1e-6);  // anchor bottom at the position's height
}

}  // namespace
}  // namespace hullpipe
