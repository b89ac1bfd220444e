// The held-out rendering error against exact cases: the masked PSNR of a known
// offset, undistortion against a pinhole rendering of the same scene, and a
// synthetic rig whose held-out view is rendered from the other cameras only
// (with a wrong texturing as the control that the measure can fail).
#include "hullpipe/evaluation/held_out_rendering.h"

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

TEST(HeldOutRendering, MaskedPsnrOfAKnownOffsetAndOnlyInsideTheMask) {
  cv::Mat truth(40, 50, CV_8UC3, cv::Scalar(100, 120, 140)), mask(40, 50, CV_8UC1, cv::Scalar(0));
  mask(cv::Rect(10, 10, 20, 15)).setTo(255);
  cv::Mat rendered = truth.clone();
  rendered.setTo(cv::Scalar(0, 0, 0), ~mask);  // outside the mask: ignored
  const ImageError same = MaskedImageError(truth, rendered, mask);
  EXPECT_EQ(same.pixels, 20 * 15);
  EXPECT_EQ(same.psnr_db, ImageError::kMaxPsnrDb);
  EXPECT_NEAR(same.ssim, 1.0, 1e-9);
  rendered(cv::Rect(10, 10, 20, 15)) += cv::Scalar(5, 5, 5);  // MSE 25 exactly
  const ImageError off = MaskedImageError(truth, rendered, mask);
  EXPECT_NEAR(off.psnr_db, 20 * std::log10(255.0 / 5.0), 1e-12);
  EXPECT_LT(off.ssim, 1.0);
  EXPECT_THROW(MaskedImageError(truth, rendered, cv::Mat(40, 49, CV_8UC1)), std::invalid_argument);
}

// A distorted camera's exact map and image, resampled to its pinhole, against
// the exact map and image of the same camera without distortion.
TEST(HeldOutRendering, UndistortionMatchesThePinholeRendering) {
  const SyntheticScene scene = NamedScene("mixed", 0.2);
  const Distortion barrel{-0.25, 0.08, 0.001, -0.001, 0};
  const Camera distorted = DomeCameras(3, 1.6, Eigen::Vector3d(0, 0, -1), 200, 150, 1.3, barrel)[0];
  Camera pinhole = distorted;
  pinhole.distortion = {};
  const PinholeTruth t =
      UndistortToPinhole(distorted, RenderColour(distorted, scene), RenderExactMap(distorted, scene));
  const cv::Mat map = RenderExactMap(pinhole, scene);
  // Nearest-pixel resampling moves a silhouette by at most half a pixel each
  // way, so only pixels on the pinhole silhouette's border may differ.
  cv::Mat border;
  cv::morphologyEx(map, border, cv::MORPH_GRADIENT, cv::Mat::ones(3, 3, CV_8UC1));
  EXPECT_EQ(cv::countNonZero((t.map != map) & ~border), 0);
  ASSERT_GT(cv::countNonZero(map), 500);
  const double iou = double(cv::countNonZero(t.map & map)) / cv::countNonZero(t.map | map);
  EXPECT_GT(iou, 0.97);
  // Colour over the whole image that maps onto the distorted one (the floor's
  // checkers included), away from the silhouettes where bilinear resampling
  // mixes object and background. Control: the distorted image taken as if it
  // were the pinhole one is far worse.
  const cv::Mat full(map.size(), CV_8UC1, cv::Scalar(255));
  cv::Mat inside;
  cv::erode(UndistortToPinhole(distorted, RenderColour(distorted, scene), full).map, inside,
            cv::Mat::ones(3, 3, CV_8UC1));
  inside &= ~border;
  const ImageError resampled = MaskedImageError(RenderColour(pinhole, scene), t.image, inside);
  const ImageError raw = MaskedImageError(RenderColour(pinhole, scene), RenderColour(distorted, scene), inside);
  EXPECT_GT(resampled.psnr_db, 30.0);  // measured 31.9 dB; the control 23.2
  EXPECT_GT(resampled.psnr_db, raw.psnr_db + 8.0);
  // Without distortion it is the identity.
  const cv::Mat img = RenderColour(pinhole, scene);
  const PinholeTruth same = UndistortToPinhole(pinhole, img, map);
  EXPECT_EQ(cv::countNonZero(same.map != map), 0);
  EXPECT_EQ(cv::norm(same.image, img, cv::NORM_INF), 0.0);
}

struct HeldOutRig {
  std::vector<CameraMap> views;
  std::vector<cv::Mat> images;
};

HeldOutRig MakeRig(const SyntheticScene& scene, int n) {
  HeldOutRig rig;
  for (const auto& c : DomeCameras(n, 2.5, Eigen::Vector3d(0, 0, -1), 160, 120, 1.0)) {
    rig.views.push_back({c, RenderExactMap(c, scene)});
    rig.images.push_back(RenderColour(c, scene));
  }
  return rig;
}

TEST(HeldOutRendering, TheOtherCamerasRenderTheHeldOutView) {
  const SyntheticScene scene = NamedScene("sphere", 0);
  HeldOutRig rig = MakeRig(scene, 8);
  HeldOutOptions o;
  o.sweep.num_planes = 96;
  const size_t k = 2;
  const HeldOutResult r = RenderHeldOut(rig.views, rig.images, test::BigBox(), k, o);
  // The hull of 7 cameras contains the sphere, so it covers the held-out map
  // (up to the sweep's sub-pixel silhouette) and adds only the little phantom
  // volume 7 dome cameras leave around a sphere.
  EXPECT_LE(cv::countNonZero(r.truth.map & ~r.hull), 0.01 * cv::countNonZero(r.truth.map));
  EXPECT_GT(r.iou, 0.9);
  // Colour: Lambertian shading, so what differs is where the hull's phantom
  // volume puts a point off the sphere (textured from another spot of it, or
  // from the background past its rim). Measured 23.5 dB and SSIM 0.78 over the
  // map (27.9 dB, 0.90 three pixels inside it); the bounds leave 1.5 dB.
  EXPECT_GT(r.error.psnr_db, 22.0);
  EXPECT_GT(r.error.ssim, 0.72);
  // The held-out camera's own map and image play no part in the rendering.
  HeldOutRig blind = rig;
  blind.views[k].map = cv::Mat(blind.views[k].map.size(), CV_8UC1, cv::Scalar(255));
  blind.images[k] = cv::Mat(blind.images[k].size(), CV_8UC3, cv::Scalar(0, 255, 0));
  const HeldOutResult b = RenderHeldOut(blind.views, blind.images, test::BigBox(), k, o);
  EXPECT_EQ(cv::norm(b.rendered, r.rendered, cv::NORM_INF), 0.0);
  // Control: the same hull textured with the images in the wrong cameras must
  // score clearly worse, or the measure could not tell texturing apart.
  HeldOutRig shuffled = rig;
  for (size_t i = 0; i < shuffled.images.size(); ++i) shuffled.images[i] = rig.images[(i + 3) % rig.images.size()];
  const HeldOutResult s = RenderHeldOut(shuffled.views, shuffled.images, test::BigBox(), k, o);
  EXPECT_EQ(s.iou, r.iou);
  // (measured 16.9 dB and 0.69).
  EXPECT_LT(s.error.psnr_db, r.error.psnr_db - 4.0);
  EXPECT_LT(s.error.ssim, r.error.ssim - 0.05);
}

TEST(HeldOutRendering, RefusesTooFewCamerasAndMismatchedImages) {
  HeldOutRig rig = MakeRig(NamedScene("sphere", 0), 3);
  EXPECT_THROW(RenderHeldOut(rig.views, rig.images, test::BigBox(), 3), std::invalid_argument);
  rig.images[1] = cv::Mat(10, 10, CV_8UC3);
  EXPECT_THROW(RenderHeldOut(rig.views, rig.images, test::BigBox(), 0), std::invalid_argument);
  rig.views.pop_back();
  rig.images.pop_back();
  EXPECT_THROW(RenderHeldOut(rig.views, rig.images, test::BigBox(), 0), std::invalid_argument);
}

}  // namespace
}  // namespace hullpipe
