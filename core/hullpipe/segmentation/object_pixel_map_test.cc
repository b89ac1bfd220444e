#include "hullpipe/segmentation/object_pixel_map.h"

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
