// Background model and segmentation into object-pixel maps (paper §3.1: "each
// camera's image is compared against a reference background image").
//
// Model: a per-pixel median background (BGR) and per-pixel spread of brightness,
// learnt from frames of the empty scene. A pixel is object when it differs from
// the background in brightness beyond max(threshold, k * spread), or in hue (where
// both are saturated enough for hue to mean something) or saturation; a darker
// pixel whose hue and saturation match is a shadow and stays background. Then the
// map is cleaned: a morphological opening removes speckle, a closing fills cracks,
// components smaller than a fraction of the image or of the largest component are
// dropped, and holes inside
// the remaining components are filled when they are small.
#pragma once

#include <memory>
#include <vector>

#include <opencv2/core.hpp>

namespace hullpipe {

/// Segmentation settings. Colour differences are in OpenCV 8-bit HSV units
/// (H in [0,180), S and V in [0,255]).
struct SegmentationOptions {
  double value_threshold = 30;     ///< |V - V_bg| above this is object...
  double value_noise_k = 4;        ///< ...and above k * the pixel's V spread.
  double hue_threshold = 12;       ///< circular |H - H_bg| above this is object...
  double hue_min_saturation = 60;  ///< ...when both S and S_bg exceed this.
  double saturation_threshold = 60;  ///< |S - S_bg| above this is object.
  double shadow_min_ratio = 0.45;  ///< V/V_bg in [min, max] with matching H, S
  double shadow_max_ratio = 0.95;  ///<   is shadow (background).
  int open_radius = 1;             ///< Opening kernel radius in pixels (0 = none).
  int close_radius = 3;            ///< Closing kernel radius in pixels (0 = none).
  double min_component_fraction = 0.002;  ///< Drop components below this * image area.
  /// Drop components smaller than this * the largest one. The real objects are
  /// the largest; clutter that appeared after the background was recorded (the
  /// Utrecht rig's checkerboard, in cam3's view only) is smaller. 0 keeps every
  /// component (several separate objects of very different sizes).
  double min_component_ratio = 0.3;
  /// Fill background holes enclosed by an object when smaller than this * image
  /// area (segmentation noise); larger holes are real gaps (an arm akimbo) and stay.
  double max_hole_fraction = 0.002;
  /// Throws std::invalid_argument naming the bad field.
  void Check() const;
};

/// A learnt reference background for one camera.
class BackgroundModel {
 public:
  BackgroundModel() = default;
  /// Learns the model from frames of the empty scene (CV_8UC3 BGR, all one size,
  /// at least one). Throws std::invalid_argument on empty input or mixed sizes.
  explicit BackgroundModel(const std::vector<cv::Mat>& empty_frames);

  /// Segments a BGR frame of the model's size into an object-pixel map (CV_8UC1,
  /// 0/255): ObjectPixels, then CleanObjectPixelMap. Throws std::invalid_argument
  /// if the frame's size or type differs or the options fail Check().
  cv::Mat Segment(const cv::Mat& frame_bgr, const SegmentationOptions& options = {}) const;

  /// The per-pixel test of paper §3.1 alone, before cleaning (CV_8UC1, 0/255).
  /// Frame and background in OpenCV's 8-bit HSV (cv::COLOR_BGR2HSV); a pixel is
  /// object when its circular hue distance |H - H_bg| exceeds hue_threshold with
  /// both S and S_bg above hue_min_saturation, or |S - S_bg| exceeds
  /// saturation_threshold, or |V - V_bg| (as floats) exceeds the float
  /// max(value_threshold, value_noise_k * spread) and is not a shadow: V < V_bg
  /// with the float ratio V / V_bg in [shadow_min_ratio, shadow_max_ratio]. Each
  /// comparison is made on the bytes with per-pixel thresholds derived from the
  /// options once per model (and again after Follow), and gives what the float
  /// rule gives, to the pixel. Throws as Segment.
  cv::Mat ObjectPixels(const cv::Mat& frame_bgr, const SegmentationOptions& options = {}) const;

  /// Follows slow lighting change (the reference background of paper §3.1, kept
  /// current for live cameras): scales the whole model by the frame's brightness
  /// gain per channel, measured over the pixels `map` (CV_8UC1, the frame's
  /// object-pixel map) calls background — so pixels hidden by the object follow too —
  /// then blends those background pixels towards the frame at `rate` in [0, 1]
  /// per frame. The spread is kept. Throws std::invalid_argument on sizes or types
  /// that differ from the model's, or a rate outside [0, 1].
  void Follow(const cv::Mat& frame_bgr, const cv::Mat& map, double rate);
  bool empty() const { return background_bgr_.empty(); }
  cv::Size size() const { return background_bgr_.size(); }
  /// The learnt background (CV_8UC3 BGR): per pixel and channel, the median of
  /// at most 31 of the frames, evenly spaced (index n / 2 of the sorted values).
  const cv::Mat& background_bgr() const { return background_bgr_; }
  /// Per-pixel robust spread of brightness (CV_32F, HSV value units): 1.4826
  /// times the median absolute deviation of V from its median over the same
  /// frames (a normal distribution's sigma).
  const cv::Mat& value_spread() const { return value_spread_; }

 private:
  struct Rule;   // per-pixel byte thresholds of one set of options (segmentation.cc)
  struct Rules;  // the last Rule made, shared by copies of one model
  std::shared_ptr<const Rule> RuleFor(const SegmentationOptions& options) const;

  cv::Mat background_bgr_;  // CV_8UC3 median
  cv::Mat background_hsv_;  // CV_8UC3
  cv::Mat background_planes_[3];  // its H, S, V planes (CV_8UC1 each)
  cv::Mat value_spread_;    // CV_32F, per-pixel robust spread of V (MAD * 1.4826)
  cv::Mat background_f_;    // CV_32FC3, the model Follow() keeps (created on first use)
  std::shared_ptr<Rules> rules_;  // made afresh by the constructor and by Follow()
};

/// Removes speckle, fills cracks and holes, drops small components (the cleaning
/// steps of SegmentationOptions) in place on a CV_8UC1 map (0 or 255). Works in
/// the object pixels' bounding box widened by the two radii (and 2 px): the
/// result equals CleanObjectPixelMapIn over the whole map, pixel for pixel.
void CleanObjectPixelMap(cv::Mat& map, const SegmentationOptions& options);

/// The same cleaning within `region` of `map` only (the reference over the whole
/// map). `region` must hold every object pixel with the radii's margin, or the
/// pixels outside it are left as they are; component and hole sizes are
/// fractions of the whole map.
void CleanObjectPixelMapIn(cv::Mat& map, const cv::Rect& region, const SegmentationOptions& options);

}  // namespace hullpipe
