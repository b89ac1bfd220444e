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
  for (const char* name : {"ball", "ball_blocks", "curtain", "particles", "payload"}) {
    const std::string path = std::string(HULLPIPE_SOURCE_DIR) + "/scenes/" + name + ".yaml";
    EXPECT_NO_THROW(VirtualScene(LoadSceneConfig(path))) << path;
  }
}

}  // namespace
}  // namespace hullpipe
