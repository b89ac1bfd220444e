// Scene files and the scene element registry: every shipped scene loads, bad
// files name the file and key, every registered kind is read from its section,
// stepped and published.
#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <fstream>

#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/scenes/ball.h"
#include "hullpipe/scenes/cloth.h"
#include "hullpipe/geometry/head_pose.h"
#include "hullpipe/scenes/particles.h"
#include "hullpipe/scenes/payload.h"
#include "hullpipe/geometry/rigid3.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/scenes/virtual_scene.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

TEST(SceneFiles, EveryShippedSceneLoads) {
  for (const char* name :
       {"ball", "ball_blocks", "bat", "bat_rig", "curtain", "particles", "payload", "payload_engine", "lighting"}) {
    const std::string path = std::string(HULLPIPE_SOURCE_DIR) + "/scenes/" + name + ".yaml";
    EXPECT_NO_THROW(VirtualScene(LoadSceneConfig(path))) << path;
  }
}

// Scene files that were silently read as something else, or made sim_node step
// without end: one error naming the file and the key.
TEST(SceneFiles, BadFilesNameTheKey) {
  const std::string dir = ::testing::TempDir();
  const std::string ball = "balls: [{radius: 0.1, start: [1, 0, -1], target: [0, 0, -1]}]\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "not a scene"},                                        // empty: was the default scene
      {"- 1\n- 2\n", "not a scene"},                              // a list
      {"gravity: [0, 0, 9.81]\n", "key 'balls' is missing"},       // was the default ball
      {"ball: []\n", "unknown key 'ball'"},                        // misspelt: was the default ball
      {"balls: []\nparticle: {emitter: [0, 0, 0]}\n", "unknown key 'particle'"},
      {"balls: [{radius: 0.1, start: [1, 0, -1]}]\n", "key 'balls[0].target' is missing"},
      {"balls: [{radius: 0.1, start: [1, 0, -1], target: [0, 0, -1], speed: 2}]\n", "unknown key 'balls[0].speed'"},
      {ball + "max_substep: 1e-9\n", "max_substep must be in [1e-4, 0.1] s"},  // was a hang
      {ball + "max_substep: 5\n", "max_substep must be in [1e-4, 0.1] s"},
      {"balls: []\ncloth: {rod_a: [0, -1, -2], rod_b: [0, 1, -2], length: 1, max_substep: 1e-9}\n",
       "max_substep must be in [1e-4, 0.1] s"},
      {"balls: []\ncloth: {rod_a: [0, -1, -2], length: 1}\n", "key 'cloth.rod_b' is missing"},
      {"balls: []\ncollision: {max_pixel: 0.01}\n", "unknown key 'collision.max_pixel'"},
      {"balls: []\nhull_velocity: {max_sped: 5}\n", "unknown key 'hull_velocity.max_sped'"},
      {"balls: []\nhull_velocity: {max_speed: -1}\n", "hull_velocity.max_speed must be in (0, 1000] m/s"},
      {"balls: []\nhull_velocity: {max_interval: .nan}\n", "hull_velocity.max_interval must be in (0, 10] s"},
      {"balls: 3\n", "'balls' must be a list"},
      // The triangle query's viewport: 200,000 px a side hung sim_node past SIGINT.
      {"balls: []\ncollision: {fixed_viewport: 200000}\n", "collision: fixed_viewport must be in [0, 256] pixels"},
      {"balls: []\ncollision: {max_viewport: 100000, max_pixel_size: 1e-9}\n",
       "collision: max_pixel_size must be in [1e-05, 1] m"},
      {"balls: []\ncollision: {max_viewport: 100000}\n", "collision: max_viewport must be in [1, 256] pixels"},
      // 5000 balls at subdivision 5 took 2.5 GB past SIGINT.
      {[] {
         std::string t = "balls:\n";
         for (int k = 0; k < 300; ++k) t += "  - {radius: 0.1, start: [1, 0, -1], target: [0, 0, -1]}\n";
         return t;
       }(),
       "300 balls; at most 256"},
      {[] {
         std::string t = "balls:\n";
         for (int k = 0; k < 60; ++k)
           t += "  - {radius: 0.1, start: [1, 0, -1], target: [0, 0, -1], subdivisions: 5}\n";
         return t;
       }(),
       "the balls have 1228800 triangles together; at most 1048576"},
      // render_node keys what it draws by object id: a ball and the curtain
      // both 100 drew one in place of the other.
      {"balls: [{id: 100, radius: 0.1, start: [1, 0, -1], target: [0, 0, -1]}]\n"
       "cloth: {rod_a: [0, -1, -2], rod_b: [0, 1, -2], length: 1}\n",
       "object ids overlap: ball 100 (100) and cloth (100)"},
      {"balls: []\ncloth: {id: 301, rod_a: [0, -1, -2], rod_b: [0, 1, -2], length: 1}\npayload: {spacing: 0.2}\n",
       "object ids overlap: payload (300..302) and cloth (301)"},
      {"balls: [{id: 2, radius: 0.1, start: [1, 0, -1], target: [0, 0, -1]},\n"
       "        {radius: 0.1, start: [1, 0, -1], target: [0, 0, -1]}]\n",
       "object ids overlap: ball 2 (2) and ball 2 (2)"},
      // A 2-MiB file is refused before it is parsed.
      {ball + "# " + std::string(2 << 20, 'x') + "\n", "2 MiB; a scene file is at most 1 MiB"},
  };
  int i = 0;
  for (const auto& [text, words] : cases) {
    const std::string path = dir + "/scene_bad_" + std::to_string(i++) + ".yaml";
    std::ofstream(path) << text;
    try {
      LoadSceneConfig(path);
      ADD_FAILURE() << text << ": loaded";
    } catch (const std::runtime_error& e) {
      const std::string msg = e.what();
      EXPECT_EQ(msg.rfind(path + ": ", 0), 0u) << msg;
      EXPECT_NE(msg.find(words), std::string::npos) << text << " -> " << msg;
    }
  }
  // Control: the smallest valid file.
  const std::string ok = dir + "/scene_ok.yaml";
  std::ofstream(ok) << ball;
  ASSERT_NE(LoadSceneConfig(ok).Find<BallsConfig>(), nullptr);
  EXPECT_EQ(LoadSceneConfig(ok).Find<BallsConfig>()->balls.size(), 1u);
}

}  // namespace
}  // namespace hullpipe

namespace hullpipe {
namespace {

// Every registered kind (scene_elements.cc) is read from its own section, in
// the registry's order, stepped with the balls and published with its meshes;
// an unknown section is refused naming every known key, the kinds' among them.
TEST(SceneElements, EveryRegisteredKindIsReadSteppedAndPublished) {
  const std::string path = ::testing::TempDir() + "elements.yaml";
  // A one-triangle model beside the scene file (its path is relative to it).
  std::ofstream(::testing::TempDir() + "elements_tri.obj") << "o tri\nv 0 0 0\nv 100 0 0\nv 0 100 0\nf 1 2 3\n";
  std::ofstream(path) << "balls: [{radius: 0.1, start: [1, 0, -1], target: [0, 0, -1]}]\n"
                         "models: [{file: elements_tri.obj, units: mm}]\n"
                         "payload: {spacing: 0.2}\n"
                         "particles: {emitter: [0.3, 0, -2.2], velocity: [0, 0, 0.5], rate: 100}\n"
                         "cloth: {rod_a: [0, -0.6, -1.8], rod_b: [0, 0.6, -1.8], length: 1.2}\n";
  const SceneConfig cfg = LoadSceneConfig(path);
  ASSERT_EQ(cfg.elements.size(), SceneElementKinds().size());
  for (size_t i = 0; i < cfg.elements.size(); ++i) EXPECT_EQ(cfg.elements[i]->Key(), SceneElementKinds()[i].key);
  ASSERT_NE(cfg.Find<PayloadConfig>(), nullptr);
  EXPECT_EQ(cfg.Find<PayloadConfig>()->spacing, 0.2);
  VirtualScene scene(cfg);
  EXPECT_EQ(scene.Describe().rfind("1 ball(s), a curtain, particles, the payload task, model elements_tri.obj", 0), 0u)
      << scene.Describe();
  scene.Step(0.1, nullptr);
  const ElementOutput out = scene.Output(0.1, 7);
  EXPECT_EQ(out.states.size(), 1u);   // the ball
  EXPECT_EQ(out.reports.size(), 1u);
  ASSERT_EQ(out.meshes.size(), 5u);   // the curtain, the particles, three payload parts
  EXPECT_EQ(out.meshes[0].kind, kMeshCloth);
  EXPECT_EQ(out.meshes[1].kind, kMeshParticles);
  EXPECT_GT(out.meshes[1].draw.vertices.size(), 0u);  // emitted in 0.1 s at 100/s
  for (size_t k = 2; k < 5; ++k) EXPECT_EQ(out.meshes[k].kind, kMeshPart);
  // Each mesh names the element that published it (render_node's stats.json).
  EXPECT_EQ(out.meshes[0].element, "cloth");
  EXPECT_EQ(out.meshes[1].element, "particles");
  for (size_t k = 2; k < 5; ++k) EXPECT_EQ(out.meshes[k].element, "payload");
  EXPECT_TRUE(out.events.empty());  // no hull: nothing collides
  ASSERT_EQ(out.model_parts.size(), 1u);  // the model's one part, once
  ASSERT_EQ(out.model_states.size(), 1u);
  EXPECT_EQ(out.model_parts[0].name, "tri");
  scene.Step(0.1, nullptr);
  EXPECT_TRUE(scene.Output(0.2, 8).model_parts.empty()) << "geometry goes once";

  std::ofstream(path) << "balls: []\ncurtain: {}\n";
  try {
    LoadSceneConfig(path);
    ADD_FAILURE() << "an unknown section was accepted";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("unknown key 'curtain'"), std::string::npos) << what;
    for (const auto& kind : SceneElementKinds()) EXPECT_NE(what.find(kind.key), std::string::npos) << what;
  }
}

// Elements set in code take the registry's order (the order they step and
// publish in), whatever order they are set in; setting a kind again replaces
// it; a scene with two of one kind is refused naming it.
TEST(SceneElements, SetKeepsTheRegistrysOrderAndOneOfEachKind) {
  SceneConfig cfg;
  cfg.Set(PayloadConfig{});
  cfg.Set(ParticleConfig{});
  BallConfig ball;
  ball.id = 7;
  cfg.Set(BallsConfig({ball}));
  cfg.Set(BallsConfig({ball, [] {
                         BallConfig b;
                         b.id = 8;
                         return b;
                       }()}));  // replaces the first
  ASSERT_EQ(cfg.elements.size(), 3u);
  EXPECT_EQ(cfg.elements[0]->Key(), "balls");
  EXPECT_EQ(cfg.elements[1]->Key(), "particles");
  EXPECT_EQ(cfg.elements[2]->Key(), "payload");
  EXPECT_EQ(cfg.Find<BallsConfig>()->balls.size(), 2u);
  EXPECT_NO_THROW(cfg.Check());
  VirtualScene scene(cfg);
  ASSERT_NE(scene.balls(), nullptr);
  EXPECT_EQ(scene.balls()->bodies().size(), 2u);
  EXPECT_EQ(scene.Describe().rfind("2 ball(s), particles, the payload task", 0), 0u) << scene.Describe();

  cfg.elements.push_back(std::make_shared<BallsConfig>());
  try {
    cfg.Check();
    ADD_FAILURE() << "two balls elements were accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("two 'balls' elements"), std::string::npos) << e.what();
  }
  SceneConfig none;  // control: no elements, no balls
  EXPECT_EQ(VirtualScene(none).balls(), nullptr);
  EXPECT_EQ(VirtualScene(DefaultScene()).balls()->bodies().size(), 1u);
}

}  // namespace
}  // namespace hullpipe
