// Joining a novel view's tiles (paper §3.3 with §5's split of the view across
// recon nodes): the joined view equals the unsplit one pixel for pixel, and the
// gathering by pose is bounded against lost and hostile tiles.
#include "hullpipe/reconstruction/tile_set.h"

#include <atomic>

#include <gtest/gtest.h>

#include "hullpipe/geometry/conventions.h"

namespace hullpipe {
namespace {

// A view's hull depth and colour with a different value at every pixel, and
// no hull in its left column.
HullViewImage Whole(int width, int height) {
  HullViewImage v;
  v.depth = cv::Mat(height, width, CV_32FC1);
  v.colour = cv::Mat(height, width, CV_8UC3);
  for (int r = 0; r < height; ++r)
    for (int c = 0; c < width; ++c) {
      v.depth.at<float>(r, c) = c == 0 ? kNoDepth : 1.0f + 0.001f * float(r * width + c);
      v.colour.at<cv::Vec3b>(r, c) = {uchar(r), uchar(c), uchar(r + c)};
    }
  return v;
}

HullTile Tile(const HullViewImage& whole, cv::Rect rect, uint32_t index, uint32_t count, uint64_t pose) {
  HullTile t;
  t.rect = rect;
  t.depth = whole.depth(rect).clone();
  t.colour = whole.colour(rect).clone();
  t.tile_index = index;
  t.tile_count = count;
  t.pose_seq = pose;
  return t;
}

bool Equal(const cv::Mat& a, const cv::Mat& b) {
  // Exact, +inf included (cv::norm is not defined on infinities).
  return a.size() == b.size() && a.type() == b.type() &&
         std::equal(a.datastart, a.dataend, b.datastart, b.dataend);
}

// Tiles in any order give the unsplit view exactly: pasting copies, nothing is
// resampled, so no tolerance.
TEST(TileSet, TilesInAnyOrderJoinIntoTheUnsplitViewExactly) {
  const HullViewImage whole = Whole(64, 48);
  TileSet set;
  EXPECT_FALSE(set.Add(Tile(whole, {0, 24, 64, 24}, 1, 2, 7)));
  const auto joined = set.Add(Tile(whole, {0, 0, 64, 24}, 0, 2, 7));
  ASSERT_TRUE(joined);
  EXPECT_TRUE(Equal(joined->depth, whole.depth));
  EXPECT_TRUE(Equal(joined->colour, whole.colour));
  EXPECT_EQ(set.pending(), 0u);
  EXPECT_EQ(set.refused() + set.dropped(), 0);
}

// Two poses interleaved complete independently; a tile sent twice does not
// stand in for the one still missing.
TEST(TileSet, PosesCompleteIndependentlyAndARepeatedTileIsNotCountedTwice) {
  const HullViewImage a = Whole(32, 32), b = Whole(32, 32);
  TileSet set;
  EXPECT_FALSE(set.Add(Tile(a, {0, 0, 32, 16}, 0, 2, 1)));
  EXPECT_FALSE(set.Add(Tile(b, {0, 0, 32, 16}, 0, 2, 2)));
  EXPECT_FALSE(set.Add(Tile(a, {0, 0, 32, 16}, 0, 2, 1)));  // repeated: pose 1 still lacks tile 1
  EXPECT_EQ(set.pending(), 2u);
  EXPECT_TRUE(set.Add(Tile(b, {0, 16, 32, 16}, 1, 2, 2)));
  EXPECT_TRUE(set.Add(Tile(a, {0, 16, 32, 16}, 1, 2, 1)));
  EXPECT_EQ(set.pending(), 0u);
}

// Every kind of tile that cannot belong to a view is refused and counted, and
// none of them completes a pose (positive control: the good tile does).
TEST(TileSet, TilesThatCannotBelongToAViewAreRefusedAndCounted) {
  const HullViewImage whole = Whole(16, 16);
  TileSet set;
  HullTile zero = Tile(whole, {0, 0, 16, 16}, 0, 1, 1);
  zero.tile_count = 0;
  HullTile index = Tile(whole, {0, 0, 16, 16}, 0, 1, 1);
  index.tile_index = 1;
  HullTile many = Tile(whole, {0, 0, 16, 16}, 0, TileSet::kMaxTiles + 1, 1);
  HullTile outside = Tile(whole, {0, 0, 16, 16}, 0, 1, 1);
  outside.rect.x = kMaxViewSide - 8;  // 8 columns past the largest view
  HullTile negative = Tile(whole, {0, 0, 16, 16}, 0, 1, 1);
  negative.rect.y = -1;
  HullTile small = Tile(whole, {0, 0, 16, 16}, 0, 1, 1);
  small.depth = small.depth(cv::Rect(0, 0, 8, 16)).clone();
  HullTile type = Tile(whole, {0, 0, 16, 16}, 0, 1, 1);
  type.colour.convertTo(type.colour, CV_32FC3);
  for (HullTile* t : {&zero, &index, &many, &outside, &negative, &small, &type}) EXPECT_FALSE(set.Add(*t));
  EXPECT_EQ(set.refused(), 7);
  // A count that differs from its pose's first tile's.
  EXPECT_FALSE(set.Add(Tile(whole, {0, 0, 16, 8}, 0, 2, 2)));
  EXPECT_FALSE(set.Add(Tile(whole, {0, 8, 16, 8}, 1, 3, 2)));
  EXPECT_EQ(set.refused(), 8);
  EXPECT_TRUE(set.Add(Tile(whole, {0, 0, 16, 16}, 0, 1, 1)));
}

// A pose whose tile is lost waits until kPendingPoses newer poses are seen,
// then is dropped and counted; a tile older than that is refused, even at the
// ends of the pose counter's range (no wrap-around).
TEST(TileSet, APoseMissingATileIsDroppedAfterTheNewerPosesAndLateTilesAreRefused) {
  const HullViewImage whole = Whole(8, 8);
  TileSet set;
  EXPECT_FALSE(set.Add(Tile(whole, {0, 0, 8, 4}, 0, 2, 10)));  // its tile 1 never comes
  EXPECT_TRUE(set.Add(Tile(whole, {0, 0, 8, 8}, 0, 1, 10 + TileSet::kPendingPoses)));
  EXPECT_EQ(set.pending(), 1u);
  EXPECT_EQ(set.dropped(), 0);
  EXPECT_TRUE(set.Add(Tile(whole, {0, 0, 8, 8}, 0, 1, 11 + TileSet::kPendingPoses)));
  EXPECT_EQ(set.pending(), 0u);
  EXPECT_EQ(set.dropped(), 1);
  EXPECT_FALSE(set.Add(Tile(whole, {0, 4, 8, 4}, 1, 2, 10)));  // its tile, too late: the pose is gone
  EXPECT_EQ(set.pending(), 1u);  // (it starts a pose of its own, dropped like any other)
  EXPECT_EQ(set.refused(), 0);

  TileSet ends;
  EXPECT_FALSE(ends.Add(Tile(whole, {0, 0, 8, 4}, 0, 2, UINT64_MAX - 1)));
  EXPECT_FALSE(ends.Add(Tile(whole, {0, 0, 8, 4}, 0, 2, 3)));  // 2^64 - 4 poses older: refused
  EXPECT_EQ(ends.refused(), 1);
  EXPECT_TRUE(ends.Add(Tile(whole, {0, 4, 8, 4}, 1, 2, UINT64_MAX - 1)));
}

// The waiting tiles' pixels are bounded: past the bound the oldest poses go
// (the default bound is two views of the largest size; a small one here).
TEST(TileSet, TheWaitingTilesPixelsAreBoundedOldestPoseFirst) {
  const HullViewImage whole = Whole(16, 16);
  TileSet set(3 * 16 * 8);  // three half views
  for (uint64_t pose = 1; pose <= 4; ++pose) EXPECT_FALSE(set.Add(Tile(whole, {0, 0, 16, 8}, 0, 2, pose)));
  EXPECT_EQ(set.pending(), 3u);
  EXPECT_EQ(set.dropped(), 1);
  EXPECT_FALSE(set.Add(Tile(whole, {0, 8, 16, 8}, 1, 2, 1)));  // pose 1 was dropped first
  EXPECT_TRUE(set.Add(Tile(whole, {0, 8, 16, 8}, 1, 2, 4)));
}

// PasteTiles leaves out what does not fit the view and fills what no tile
// covers with no hull.
TEST(PasteTiles, LeavesOutTilesOutsideTheViewAndFillsTheRestWithNoHull) {
  const HullViewImage whole = Whole(16, 16);
  const HullTile left = Tile(whole, {0, 0, 8, 16}, 0, 2, 1);
  HullTile outside = Tile(whole, {8, 0, 8, 16}, 1, 2, 1);
  outside.rect.x = 12;  // 4 columns past a 16-wide view
  const HullViewImage v = PasteTiles({&left, &outside, nullptr}, {16, 16});
  EXPECT_TRUE(Equal(v.depth(cv::Rect(0, 0, 8, 16)).clone(), whole.depth(cv::Rect(0, 0, 8, 16)).clone()));
  for (int r = 0; r < 16; ++r)
    for (int c = 8; c < 16; ++c) {
      EXPECT_EQ(v.depth.at<float>(r, c), kNoDepth);
      EXPECT_EQ(v.colour.at<cv::Vec3b>(r, c), cv::Vec3b(0, 0, 0));
    }
}

// A stop request ends the paste (polled per row and per tile); without one the
// same call pastes (positive control).
TEST(PasteTiles, AStopRequestEndsItWithInterrupted) {
  const HullViewImage whole = Whole(16, 16);
  const HullTile all = Tile(whole, {0, 0, 16, 16}, 0, 1, 1);
  std::atomic<bool> stop{true};
  EXPECT_THROW((void)PasteTiles({&all}, {16, 16}, &stop), Interrupted);
  stop = false;
  EXPECT_TRUE(Equal(PasteTiles({&all}, {16, 16}, &stop).depth, whole.depth));
}

}  // namespace
}  // namespace hullpipe
