#include "hullpipe/segmentation/object_pixel_map.h"

#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace hullpipe {
namespace {

TEST(ObjectPixelMap, RunLengthRoundTrip) {
  cv::Mat m(48, 64, CV_8UC1, cv::Scalar(0));
  cv::circle(m, {30, 20}, 12, 255, cv::FILLED);
  m.at<uint8_t>(0, 0) = 255;    // starts with an object run (first run 0)
  m.at<uint8_t>(47, 63) = 255;  // ends with one
  const auto runs = RunLengthEncode(m);
  EXPECT_EQ(runs.front(), 0u);
  const cv::Mat back = RunLengthDecode(runs, 64, 48);
  EXPECT_EQ(cv::countNonZero(back != m), 0);
}

// The word-at-a-time encoder against the plain per-pixel one: runs of every
// length around the 8-byte words, object values other than 255, and a map
// that is a view into a larger image (not continuous).
TEST(ObjectPixelMap, RunLengthEncodeEqualsThePlainPerPixelEncoder) {
  auto plain = [](const cv::Mat& map) {
    std::vector<uint32_t> runs;
    bool current = false;
    uint32_t length = 0;
    for (int r = 0; r < map.rows; ++r)
      for (int c = 0; c < map.cols; ++c) {
        const bool obj = map.at<uint8_t>(r, c) != 0;
        if (obj != current) {
          runs.push_back(length);
          length = 0;
          current = obj;
        }
        ++length;
      }
    runs.push_back(length);
    return runs;
  };
  std::mt19937 rng(3);
  for (int trial = 0; trial < 200; ++trial) {
    const int w = 1 + int(rng() % 70), h = 1 + int(rng() % 9);
    cv::Mat big(h + 2, w + 5, CV_8UC1, cv::Scalar(0));
    cv::Mat map = trial % 2 ? big(cv::Rect(3, 1, w, h)) : cv::Mat(h, w, CV_8UC1, cv::Scalar(0));
    // Runs of 0..19 pixels, object bytes 1..255.
    bool obj = rng() % 2;
    for (int i = 0; i < w * h;) {
      const int len = int(rng() % 20);
      for (int k = 0; k < len && i < w * h; ++k, ++i)
        map.at<uint8_t>(i / w, i % w) = obj ? uint8_t(1 + rng() % 255) : 0;
      obj = !obj;
    }
    ASSERT_EQ(RunLengthEncode(map), plain(map)) << w << "x" << h << " trial " << trial;
  }
}

TEST(ObjectPixelMap, EmptyAndFullMaps) {
  const cv::Mat empty(10, 10, CV_8UC1, cv::Scalar(0)), full(10, 10, CV_8UC1, cv::Scalar(255));
  EXPECT_EQ(RunLengthEncode(empty), std::vector<uint32_t>{100});
  EXPECT_EQ(RunLengthEncode(full), (std::vector<uint32_t>{0, 100}));
  EXPECT_EQ(cv::countNonZero(RunLengthDecode({0, 100}, 10, 10)), 100);
}

TEST(ObjectPixelMap, BadRunsAreRejected) {
  EXPECT_THROW(RunLengthDecode({50, 49}, 10, 10), MapDecodeError);           // short
  EXPECT_THROW(RunLengthDecode({50, 51}, 10, 10), MapDecodeError);           // long
  EXPECT_THROW(RunLengthDecode({100}, 0, 10), MapDecodeError);               // bad size
  EXPECT_THROW(RunLengthDecode({0xFFFFFFFFu, 0xFFFFFFFFu}, 10, 10), MapDecodeError);  // overflow
}

}  // namespace
}  // namespace hullpipe

namespace hullpipe {
namespace {

// The bounding rectangle and count found from the runs equal OpenCV's scan of
// the decoded map, on random maps of sparse blobs and long runs over rows, on
// one-pixel maps and on empty and full ones.
TEST(ObjectPixelMap, DecodingGivesTheExactBoundingRectangle) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 400; ++trial) {
    const int w = 1 + int(rng() % 50), h = 1 + int(rng() % 30);
    cv::Mat map(h, w, CV_8UC1, cv::Scalar(0));
    const int kind = trial % 4;
    if (kind == 0) {  // a few small blobs
      for (int b = 0; b < 1 + int(rng() % 3); ++b)
        cv::circle(map, {int(rng() % w), int(rng() % h)}, int(rng() % 4), cv::Scalar(255), -1);
    } else if (kind == 1) {  // one run crossing rows
      const int s = int(rng() % (w * h)), len = 1 + int(rng() % (2 * w + 1));
      for (int i = s; i < std::min(w * h, s + len); ++i) map.at<uint8_t>(i / w, i % w) = 255;
    } else if (kind == 2) {  // one pixel
      map.at<uint8_t>(int(rng() % h), int(rng() % w)) = 255;
    } else if (trial % 8 == 3) {
      map.setTo(255);  // full
    }  // else empty
    const auto runs = RunLengthEncode(map);
    const DecodedMap d = RunLengthDecodeMap(runs.data(), runs.size(), w, h);
    ASSERT_EQ(cv::countNonZero(d.map != map), 0) << trial;
    EXPECT_EQ(d.bounds, cv::boundingRect(map)) << w << "x" << h << " trial " << trial;
    EXPECT_EQ(d.object_pixels, cv::countNonZero(map)) << trial;
  }
}

}  // namespace
}  // namespace hullpipe
