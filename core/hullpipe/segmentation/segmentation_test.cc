#include "hullpipe/segmentation/segmentation.h"

#include <random>

#include <gtest/gtest.h>

#include "hullpipe/evaluation/reprojection.h"
#include "hullpipe/evaluation/synthetic.h"

namespace hullpipe {
namespace {

// A synthetic frame against its empty background: segmentation must recover the
// exact silhouette. Tolerance: IoU >= 0.97; the misses are border pixels where a
// shaded shape's colour is close to the wall's, plus sensor noise we add.
TEST(Segmentation, RecoversExactSilhouetteOfSyntheticFrame) {
  const auto cams = RingCameras(1, 4.0, 2.0, Eigen::Vector3d(0, 0, -0.9), 320, 240, 1.0);
  const Camera& cam = cams[0];
  const SyntheticScene scene = AnimatedFigure(0.5);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0, 2.0);
  auto noisy = [&](cv::Mat img) {
    cv::Mat n(img.size(), CV_16SC3);
    for (auto it = n.begin<cv::Vec3s>(); it != n.end<cv::Vec3s>(); ++it)
      *it = cv::Vec3s(short(noise(rng)), short(noise(rng)), short(noise(rng)));
    cv::Mat out;
    cv::add(img, n, out, cv::noArray(), CV_8UC3);
    return out;
  };
  const cv::Mat empty = RenderColour(cam, SyntheticScene{});
  std::vector<cv::Mat> bg;
  for (int i = 0; i < 8; ++i) bg.push_back(noisy(empty));
  const BackgroundModel model(bg);
  const cv::Mat map = model.Segment(noisy(RenderColour(cam, scene)));
  const cv::Mat truth = RenderExactMap(cam, scene);
  EXPECT_GE(MaskIoU(map, truth), 0.97);
}

TEST(Segmentation, EmptySceneGivesEmptyMap) {
  const auto cams = RingCameras(1, 4.0, 2.0, Eigen::Vector3d(0, 0, -0.9), 160, 120, 1.0);
  const cv::Mat empty = RenderColour(cams[0], SyntheticScene{});
  const BackgroundModel model(std::vector<cv::Mat>{empty});
  EXPECT_EQ(cv::countNonZero(model.Segment(empty)), 0);
}

TEST(Segmentation, WrongFrameSizeIsAnError) {
  const BackgroundModel model(std::vector<cv::Mat>{cv::Mat(10, 10, CV_8UC3, cv::Scalar(1, 2, 3))});
  EXPECT_THROW(model.Segment(cv::Mat(11, 10, CV_8UC3)), std::invalid_argument);
  EXPECT_THROW(BackgroundModel(std::vector<cv::Mat>{}), std::invalid_argument);
  SegmentationOptions o;
  o.shadow_min_ratio = 2;
  EXPECT_THROW(o.Check(), std::invalid_argument);
}

}  // namespace
}  // namespace hullpipe
