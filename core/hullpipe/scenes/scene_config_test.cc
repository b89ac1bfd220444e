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

TEST(SceneFiles, EveryShippedSceneLoads) {
  for (const char* name : {"ball", "ball_blocks", "curtain", "particles", "payload", "lighting"}) {
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
      {"balls: 3\n", "'balls' must be a list"},
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
  EXPECT_EQ(LoadSceneConfig(ok).balls.size(), 1u);
}

}  // namespace
}  // namespace hullpipe
