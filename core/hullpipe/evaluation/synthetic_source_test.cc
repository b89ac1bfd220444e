// The synthetic capture source: exact maps of the moving scene, its end and
// rewind, and the bounds on its sizes.
#include "hullpipe/evaluation/synthetic_source.h"

#include <cmath>

#include <gtest/gtest.h>

#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

TEST(SyntheticRig, GivesExactMaps) {
  SyntheticRigOptions o;
  o.width = 80;
  o.height = 60;
  o.frames = 2;
  const auto rig = OpenSyntheticRig(o);
  RigFrame f;
  ASSERT_TRUE(rig->Next(&f));
  ASSERT_EQ(f.maps.size(), 4u);
  EXPECT_EQ(cv::countNonZero(f.maps[1] != RenderExactMap(rig->cameras()[1], AnimatedFigure(0))), 0);
  EXPECT_GT(cv::countNonZero(f.maps[1]), 50);
  ASSERT_TRUE(rig->Next(&f));
  EXPECT_FALSE(rig->Next(&f));  // the input ends
  EXPECT_TRUE(rig->Rewind());
  EXPECT_TRUE(rig->Next(&f));
}

// --synthetic-size 100000x100000 once allocated without end: bounded, named.
TEST(SyntheticRig, SizesAndCountsAreBounded) {
  auto open = [](int w, int h, int cams, double fps) {
    SyntheticRigOptions o;
    o.width = w;
    o.height = h;
    o.cameras = cams;
    o.fps = fps;
    o.frames = 1;
    return OpenSyntheticRig(o);
  };
  EXPECT_THROW(open(100000, 100000, 4, 25), std::invalid_argument);
  EXPECT_THROW(open(4097, 240, 4, 25), std::invalid_argument);
  EXPECT_THROW(open(320, 4, 4, 25), std::invalid_argument);
  EXPECT_THROW(open(320, 240, 65, 25), std::invalid_argument);
  EXPECT_THROW(open(320, 240, 4, 0), std::invalid_argument);
  EXPECT_THROW(open(320, 240, 4, std::nan("")), std::invalid_argument);
  EXPECT_NO_THROW(open(64, 48, 2, 25));  // control
}

}  // namespace
}  // namespace hullpipe
