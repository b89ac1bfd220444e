#include "hullpipe/segmentation/segmentation.h"

#include <algorithm>
#include <limits>
#include <set>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

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

// A live camera's light changes: the synthetic scene brightens by 30% over 10 s
// (25 fps) while the figure moves. A model that follows the light keeps every
// frame's map within 0.005 IoU (against the exact maps) of what the same frames give
// without the ramp — whose worst frame is 0.950 here, a limit of segmenting this
// figure against this wall, not of the light — and >= 0.94. The fixed model is the
// control and is reported (it loses the wall once the gain passes its threshold).
TEST(Segmentation, AFollowingBackgroundKeepsUpWithABrightnessRamp) {
  const auto cams = RingCameras(1, 4.0, 2.0, Eigen::Vector3d(0, 0, -0.9), 160, 120, 1.0);
  const Camera& cam = cams[0];
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0, 2.0);
  auto lit = [&](const cv::Mat& img, double gain) {
    cv::Mat out(img.size(), CV_8UC3);
    for (int r = 0; r < img.rows; ++r)
      for (int c = 0; c < img.cols; ++c)
        for (int k = 0; k < 3; ++k)
          out.at<cv::Vec3b>(r, c)[k] = cv::saturate_cast<uint8_t>(img.at<cv::Vec3b>(r, c)[k] * gain + noise(rng));
    return out;
  };
  const cv::Mat empty = RenderColour(cam, SyntheticScene{});
  std::vector<cv::Mat> bg;
  for (int i = 0; i < 8; ++i) bg.push_back(lit(empty, 0.85));
  const BackgroundModel fixed(bg);
  BackgroundModel following(bg);
  double worst_following = 1, worst_fixed = 1, worst_still = 1;
  for (int f = 0; f <= 250; ++f) {
    const double t = f / 25.0, gain = 0.85 * (1 + 0.3 * t / 10);
    const SyntheticScene scene = AnimatedFigure(t);
    const cv::Mat colour = RenderColour(cam, scene), truth = RenderExactMap(cam, scene);
    const cv::Mat frame = lit(colour, gain);
    worst_still = std::min(worst_still, MaskIoU(fixed.Segment(lit(colour, 0.85)), truth));
    const cv::Mat map = following.Segment(frame);
    following.Follow(frame, map, 0.05);
    worst_following = std::min(worst_following, MaskIoU(map, truth));
    worst_fixed = std::min(worst_fixed, MaskIoU(fixed.Segment(frame), truth));
  }
  std::printf("brightness ramp +30%% over 10 s: worst IoU following %.3f, fixed %.3f; without the ramp %.3f\n",
              worst_following, worst_fixed, worst_still);
  EXPECT_GE(worst_following, 0.94);
  EXPECT_GE(worst_following, worst_still - 0.005);
  EXPECT_LT(worst_fixed, 0.95) << "control: the ramp must defeat a fixed background, or the test shows nothing";
}

// The per-pixel rule written plainly, in floats and doubles as the options
// state it (before it was vectorized): the model's test must give exactly this
// map (before cleaning) for any frame, given its background and spread.
cv::Mat ReferenceRule(const cv::Mat& median, const cv::Mat& spread, const cv::Mat& frame,
                      const SegmentationOptions& o) {
  cv::Mat hsv, bg_hsv;
  cv::cvtColor(median, bg_hsv, cv::COLOR_BGR2HSV);
  cv::cvtColor(frame, hsv, cv::COLOR_BGR2HSV);
  cv::Mat map(frame.size(), CV_8UC1);
  for (int r = 0; r < frame.rows; ++r)
    for (int c = 0; c < frame.cols; ++c) {
      const cv::Vec3b f = hsv.at<cv::Vec3b>(r, c), b = bg_hsv.at<cv::Vec3b>(r, c);
      int dh = std::abs(int(f[0]) - int(b[0]));
      dh = std::min(dh, 180 - dh);
      const bool hue_differs = f[1] > o.hue_min_saturation && b[1] > o.hue_min_saturation && dh > o.hue_threshold;
      const bool sat_differs = std::abs(int(f[1]) - int(b[1])) > o.saturation_threshold;
      const float dv = float(f[2]) - float(b[2]);
      const bool value_differs =
          std::abs(dv) > std::max(float(o.value_threshold), float(o.value_noise_k) * spread.at<float>(r, c));
      bool object = hue_differs || sat_differs || value_differs;
      if (object && !hue_differs && !sat_differs && dv < 0 && b[2] > 0) {
        const float ratio = float(f[2]) / float(b[2]);
        if (ratio >= float(o.shadow_min_ratio) && ratio <= float(o.shadow_max_ratio)) object = false;
      }
      map.at<uint8_t>(r, c) = object ? 255 : 0;
    }
  return map;
}

// The learnt background written plainly (a sort per pixel and channel), as it
// was before its selection was vectorized: the median of at most 31 evenly
// spaced frames, and 1.4826 times the median absolute deviation of V.
void ReferenceBackground(const std::vector<cv::Mat>& frames, cv::Mat* median, cv::Mat* spread) {
  const size_t n = std::min<size_t>(frames.size(), 31);
  std::vector<cv::Mat> used, value(n);
  for (size_t i = 0; i < n; ++i) used.push_back(frames[i * frames.size() / n]);
  for (size_t i = 0; i < n; ++i) {
    cv::Mat h;
    cv::cvtColor(used[i], h, cv::COLOR_BGR2HSV);
    cv::extractChannel(h, value[i], 2);
  }
  const cv::Size size = frames[0].size();
  median->create(size, CV_8UC3);
  spread->create(size, CV_32F);
  std::vector<uint8_t> v(n);
  for (int r = 0; r < size.height; ++r)
    for (int c = 0; c < size.width; ++c) {
      for (int ch = 0; ch < 3; ++ch) {
        for (size_t i = 0; i < n; ++i) v[i] = used[i].at<cv::Vec3b>(r, c)[ch];
        std::nth_element(v.begin(), v.begin() + long(n / 2), v.end());
        median->at<cv::Vec3b>(r, c)[ch] = v[n / 2];
      }
      for (size_t i = 0; i < n; ++i) v[i] = value[i].at<uint8_t>(r, c);
      std::nth_element(v.begin(), v.begin() + long(n / 2), v.end());
      const int med = v[n / 2];
      for (auto& x : v) x = uint8_t(std::abs(int(x) - med));
      std::nth_element(v.begin(), v.begin() + long(n / 2), v.end());
      spread->at<float>(r, c) = 1.4826f * v[n / 2];
    }
}

// The background's median and spread equal the plain per-pixel sort's, to the
// bit: any number of frames (odd, even, one, past the 31 used), rows that end
// inside and on the selection's chunks of 256 bytes, values of every byte, few
// values (ties), and only 0 and 255.
TEST(Segmentation, TheLearntBackgroundIsThePerPixelMedianAndSpread) {
  std::mt19937 rng(11);
  int cases = 0;
  for (const int frames : {1, 2, 4, 5, 31, 40, 60})
    for (const int width : {1, 85, 86, 171, 300})
      for (const int kind : {0, 1, 2}) {
        std::vector<cv::Mat> bg;
        for (int k = 0; k < frames; ++k) {
          cv::Mat f(3, width, CV_8UC3);
          cv::randu(f, 0, 256);
          if (kind == 1) f = f / 64 * 64 + 7;   // four values a channel: ties
          if (kind == 2) f = f / 128 * 255;     // 0 and 255 only
          bg.push_back(f);
        }
        const BackgroundModel model(bg);
        cv::Mat median, spread;
        ReferenceBackground(bg, &median, &spread);
        const std::string what = std::to_string(frames) + " frames, width " + std::to_string(width) + ", kind " +
                                 std::to_string(kind);
        ASSERT_EQ(model.background_bgr().size(), median.size()) << what;
        EXPECT_EQ(cv::norm(model.background_bgr(), median, cv::NORM_INF), 0) << what;
        EXPECT_EQ(cv::norm(model.value_spread(), spread, cv::NORM_INF), 0) << what;
        ++cases;
      }
  EXPECT_EQ(cases, 105);
  // Control: the spread is not all zero here (the comparison can fail).
  std::vector<cv::Mat> noisy;
  for (int k = 0; k < 9; ++k) {
    cv::Mat f(4, 40, CV_8UC3);
    cv::randu(f, 100, 140);
    noisy.push_back(f);
  }
  EXPECT_GT(cv::countNonZero(BackgroundModel(noisy).value_spread()), 100);
}

// The byte test with its per-pixel thresholds gives the float rule's map to the
// pixel: noisy backgrounds (a value spread), frames with dark, light and
// coloured patches and shadows of every ratio, widths around the 16-byte steps
// (vector tails), and options at their limits: thresholds of 0, fractional
// ones, ones no difference reaches (hue 90, saturation 255 and above, an
// infinite noise factor), a hue gate that is always open (saturation below 0)
// or always shut (255), shadows of one ratio, of none and of every ratio.
// After Follow the model's thresholds follow its background.
TEST(Segmentation, TheByteTestGivesExactlyTheFloatRuleForAnyOptions) {
  std::vector<SegmentationOptions> options(14);
  options[1].value_noise_k = 1.5, options[1].shadow_min_ratio = 0.3, options[1].hue_threshold = 5;
  options[2].value_threshold = 0, options[2].value_noise_k = 0;
  options[3].value_threshold = 12.5, options[3].value_noise_k = 2.25, options[3].hue_threshold = 7.5,
  options[3].saturation_threshold = 20.5, options[3].hue_min_saturation = 30.5;
  options[4].hue_threshold = 90, options[4].saturation_threshold = 255, options[4].value_threshold = 255;
  options[5].saturation_threshold = 1e9, options[5].value_noise_k = std::numeric_limits<double>::infinity();
  options[6].hue_min_saturation = -1, options[6].hue_threshold = 0, options[6].saturation_threshold = 0;
  options[7].hue_min_saturation = 255;
  options[8].hue_min_saturation = 254.5, options[8].value_threshold = 254.5;
  options[9].shadow_min_ratio = options[9].shadow_max_ratio = 0.5;
  options[10].shadow_min_ratio = 0, options[10].shadow_max_ratio = 1;
  options[11].shadow_min_ratio = options[11].shadow_max_ratio = 1;
  options[12].shadow_min_ratio = options[12].shadow_max_ratio = 0;
  options[13].value_noise_k = 1e6, options[13].value_threshold = 0.25;
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> byte(0, 255), noise(-6, 6);
  int cases = 0;
  for (const cv::Size size : {cv::Size(37, 11), cv::Size(64, 9), cv::Size(5, 3), cv::Size(15, 2), cv::Size(16, 2),
                              cv::Size(17, 2), cv::Size(1, 4)}) {
    cv::Mat base(size, CV_8UC3);
    cv::randu(base, 0, 256);
    std::vector<cv::Mat> bg;
    for (int k = 0; k < 5; ++k) {
      cv::Mat b = base.clone();
      for (auto it = b.begin<cv::Vec3b>(); it != b.end<cv::Vec3b>(); ++it)
        for (int ch = 0; ch < 3; ++ch) (*it)[ch] = cv::saturate_cast<uint8_t>((*it)[ch] + noise(rng));
      bg.push_back(b);
    }
    BackgroundModel model(bg);
    auto frame_like = [&](const cv::Mat& from) {
      cv::Mat frame = from.clone();
      for (auto it = frame.begin<cv::Vec3b>(); it != frame.end<cv::Vec3b>(); ++it) {
        const int kind = byte(rng) % 4;  // unchanged+noise, shadow, new colour, brighter
        for (int ch = 0; ch < 3; ++ch) {
          const int v = (*it)[ch];
          (*it)[ch] = cv::saturate_cast<uint8_t>(kind == 0   ? v + noise(rng)
                                                 : kind == 1 ? v * (30 + byte(rng) % 71) / 100
                                                 : kind == 2 ? byte(rng)
                                                             : v + 40);
        }
      }
      return frame;
    };
    for (int trial = 0; trial < 3; ++trial) {
      const cv::Mat frame = frame_like(base);
      for (size_t k = 0; k < options.size(); ++k) {
        const cv::Mat ref = ReferenceRule(model.background_bgr(), model.value_spread(), frame, options[k]);
        const cv::Mat got = model.ObjectPixels(frame, options[k]);
        EXPECT_EQ(cv::countNonZero(got != ref), 0) << size << " trial " << trial << " options " << k;
        ++cases;
      }
    }
    // The background moves (Follow): the thresholds are made again from it
    // (those of the spread and of the shadow ratios carried over where the
    // options are the same: the default options are the last and the first).
    (void)model.ObjectPixels(base, options[0]);
    const cv::Mat before = model.background_bgr().clone();
    const cv::Mat lit = base * 0.6;
    model.Follow(lit, cv::Mat::zeros(size, CV_8UC1), 1.0);
    const cv::Mat frame = frame_like(base);
    ASSERT_GT(cv::norm(model.background_bgr(), before, cv::NORM_INF), 20) << "control: the background moved";
    for (size_t k = 0; k < options.size(); ++k) {
      const cv::Mat ref = ReferenceRule(model.background_bgr(), model.value_spread(), frame, options[k]);
      EXPECT_EQ(cv::countNonZero(model.ObjectPixels(frame, options[k]) != ref), 0)
          << size << " after Follow, options " << k;
    }
    // Segment is the test, then the cleaning.
    cv::Mat expected = model.ObjectPixels(frame);
    CleanObjectPixelMap(expected, SegmentationOptions{});
    EXPECT_EQ(cv::countNonZero(model.Segment(frame) != expected), 0) << size;
  }
  EXPECT_EQ(cases, 7 * 3 * 14);
  // Controls: the options tell the maps apart (a threshold read wrongly would
  // show), and the test throws on options Check() refuses.
  cv::Mat base(24, 40, CV_8UC3);
  cv::randu(base, 0, 256);
  const BackgroundModel model(std::vector<cv::Mat>{base});
  cv::Mat frame = base.clone();
  cv::randu(frame(cv::Rect(0, 0, 40, 12)), 0, 256);
  frame(cv::Rect(0, 12, 40, 12)) *= 0.7;
  std::set<std::vector<uint8_t>> distinct;
  for (const auto& o : options) {
    const cv::Mat m = model.ObjectPixels(frame, o);
    distinct.insert(std::vector<uint8_t>(m.begin<uint8_t>(), m.end<uint8_t>()));
  }
  EXPECT_GE(distinct.size(), 8u);
  SegmentationOptions bad;
  bad.value_threshold = -1;
  EXPECT_THROW(model.ObjectPixels(frame, bad), std::invalid_argument);
  EXPECT_THROW(model.Segment(frame, bad), std::invalid_argument);
}

// Cleaning only around the object pixels gives the whole map's cleaning pixel
// for pixel: blobs with holes and cracks, speckle near them or across the whole
// map, blobs cut by the map's edges and corners, an empty map.
TEST(Segmentation, CleaningAroundTheObjectEqualsCleaningTheWholeMap) {
  cv::RNG rng(20261126);
  SegmentationOptions o;
  int compared = 0, smaller = 0;
  for (int trial = 0; trial < 60; ++trial) {
    cv::Mat map(120 + trial, 160, CV_8UC1, cv::Scalar(0));
    const int blobs = trial % 4;  // 0: speckle only (or nothing)
    for (int b = 0; b < blobs; ++b) {
      // Centres may lie off the map: blobs cut by its edges.
      const cv::Point c(rng.uniform(-10, map.cols + 10), rng.uniform(-10, map.rows + 10));
      const cv::Size axes(rng.uniform(3, 40), rng.uniform(3, 40));
      cv::ellipse(map, c, axes, rng.uniform(0, 180), 0, 360, 255, cv::FILLED);
      if (rng.uniform(0, 2)) cv::circle(map, c, rng.uniform(1, 8), 0, cv::FILLED);       // a hole
      if (rng.uniform(0, 2)) cv::line(map, c, c + cv::Point(axes.width, 0), 0, 1);       // a crack
    }
    // Speckle: near the first blob only, or anywhere on the map.
    const bool local = trial % 2 == 0;
    const int specks = rng.uniform(0, 40);
    for (int k = 0; k < specks; ++k) {
      const cv::Point p = local ? cv::Point(rng.uniform(60, 100), rng.uniform(40, 80))
                                : cv::Point(rng.uniform(0, map.cols), rng.uniform(0, map.rows));
      map.at<uint8_t>(p) = 255;
    }
    cv::Mat fast = map.clone(), whole = map.clone();
    CleanObjectPixelMap(fast, o);
    CleanObjectPixelMapIn(whole, cv::Rect(0, 0, map.cols, map.rows), o);
    ASSERT_EQ(cv::countNonZero(fast != whole), 0) << "trial " << trial;
    ++compared;
    const cv::Rect box = cv::boundingRect(map);
    if (!box.empty() && box.area() < map.cols * map.rows / 2) ++smaller;
  }
  EXPECT_EQ(compared, 60);
  EXPECT_GT(smaller, 10);  // many trials cleaned well inside the map, not the whole of it
}

}  // namespace
}  // namespace hullpipe
