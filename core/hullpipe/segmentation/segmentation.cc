#include "hullpipe/segmentation/segmentation.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

namespace hullpipe {

void SegmentationOptions::Check() const {
  auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("SegmentationOptions: ") + what);
  };
  require(value_threshold >= 0, "value_threshold must be >= 0");
  require(value_noise_k >= 0, "value_noise_k must be >= 0");
  require(hue_threshold >= 0 && hue_threshold <= 90, "hue_threshold must be in [0, 90]");
  require(saturation_threshold >= 0, "saturation_threshold must be >= 0");
  require(shadow_min_ratio >= 0 && shadow_min_ratio <= shadow_max_ratio && shadow_max_ratio <= 1,
          "need 0 <= shadow_min_ratio <= shadow_max_ratio <= 1");
  require(open_radius >= 0 && close_radius >= 0, "morphology radii must be >= 0");
  require(min_component_fraction >= 0 && min_component_fraction < 1,
          "min_component_fraction must be in [0, 1)");
  require(min_component_ratio >= 0 && min_component_ratio <= 1, "min_component_ratio must be in [0, 1]");
  require(max_hole_fraction >= 0 && max_hole_fraction < 1, "max_hole_fraction must be in [0, 1)");
}

namespace {

// Bytes a selection pass takes at once (its counts and candidates stay in L1).
constexpr int kSelectChunk = 256;

// Counts, per byte x of a chunk, the row bytes below cand[x] (a fixed trip
// count over restrict pointers, so that the compiler vectorizes it; inlined,
// gcc 12 jams two rows into one scalar loop instead).
__attribute__((noinline)) void CountBelow(const uint8_t* __restrict row, const uint8_t* __restrict cand,
                                          uint8_t* __restrict count) {
  for (int x = 0; x < kSelectChunk; ++x) count[x] = uint8_t(count[x] + (row[x] < cand[x] ? 1 : 0));
}

// out[x] = the k-th smallest (from 0) of rows[0][x], ..., rows[n - 1][x], for
// x in [0, width): what std::nth_element gives for each byte position, found
// by its bits from the top. The k-th smallest is the largest m with at most k
// values below it; that count only grows with m, so each bit, from the top,
// is kept where the count stays <= k. Eight passes of byte compares over
// contiguous rows, which the compiler vectorizes, in place of a sort per byte
// (learning a 1024x768 background from 31 frames took 0.6 s a camera with
// nth_element). n <= 255 (the counts are bytes).
void SelectKthPerByte(const std::vector<const uint8_t*>& rows, int width, size_t k, uint8_t* out) {
  alignas(64) uint8_t prefix[kSelectChunk], cand[kSelectChunk], count[kSelectChunk];
  const uint8_t kth = uint8_t(k);  // k < n <= 255
  // The row's last, partial chunk is copied into zero-padded buffers.
  std::vector<uint8_t> tail;
  std::vector<const uint8_t*> tails;
  for (int x0 = 0; x0 < width; x0 += kSelectChunk) {
    const int m = std::min(kSelectChunk, width - x0);
    const std::vector<const uint8_t*>* chunk_rows = &rows;
    size_t offset = size_t(x0);
    if (m < kSelectChunk) {
      tail.assign(rows.size() * kSelectChunk, 0);
      tails.resize(rows.size());
      for (size_t i = 0; i < rows.size(); ++i) {
        std::copy(rows[i] + x0, rows[i] + x0 + m, tail.data() + i * kSelectChunk);
        tails[i] = tail.data() + i * kSelectChunk;
      }
      chunk_rows = &tails;
      offset = 0;
    }
    std::fill(prefix, prefix + kSelectChunk, uint8_t(0));
    for (int bit = 7; bit >= 0; --bit) {
      const uint8_t b = uint8_t(1u << bit);
      for (int x = 0; x < kSelectChunk; ++x) cand[x] = uint8_t(prefix[x] | b);
      std::fill(count, count + kSelectChunk, uint8_t(0));
      for (const uint8_t* row : *chunk_rows) CountBelow(row + offset, cand, count);
      for (int x = 0; x < kSelectChunk; ++x) prefix[x] = count[x] <= kth ? cand[x] : prefix[x];
    }
    std::copy(prefix, prefix + m, out + x0);
  }
}

}  // namespace

BackgroundModel::BackgroundModel(const std::vector<cv::Mat>& frames) {
  if (frames.empty()) throw std::invalid_argument("BackgroundModel: no background frames");
  const cv::Size size = frames[0].size();
  for (const auto& f : frames)
    if (f.size() != size || f.type() != CV_8UC3)
      throw std::invalid_argument("BackgroundModel: frames must all be CV_8UC3 of one size");
  // Per-pixel median over at most 31 evenly spaced frames (robust to passing
  // noise): the middle one, index n / 2, of each pixel's sorted values (for an
  // even n the upper of the two middle ones).
  const size_t n = std::min<size_t>(frames.size(), 31);
  std::vector<const cv::Mat*> used;
  for (size_t i = 0; i < n; ++i) used.push_back(&frames[i * frames.size() / n]);
  background_bgr_.create(size, CV_8UC3);
  value_spread_.create(size, CV_32F);
  const int w = size.width;
  // One row of every frame at a time: its B, G, R bytes (each byte position a
  // channel of a pixel), its values V (OpenCV's 8-bit HSV: max(B, G, R)), and
  // their distances from the median V.
  std::vector<const uint8_t*> rows(n);
  std::vector<uint8_t> value(n * size_t(w)), spread(static_cast<size_t>(w)), median_value(static_cast<size_t>(w));
  std::vector<const uint8_t*> value_rows(n);
  for (size_t i = 0; i < n; ++i) value_rows[i] = value.data() + i * size_t(w);
  for (int r = 0; r < size.height; ++r) {
    for (size_t i = 0; i < n; ++i) rows[i] = used[i]->ptr<uint8_t>(r);
    SelectKthPerByte(rows, 3 * w, n / 2, background_bgr_.ptr<uint8_t>(r));
    for (size_t i = 0; i < n; ++i) {
      uint8_t* v = value.data() + i * size_t(w);
      const uint8_t* p = rows[i];
      for (int c = 0; c < w; ++c) v[c] = std::max({p[3 * c], p[3 * c + 1], p[3 * c + 2]});
    }
    SelectKthPerByte(value_rows, w, n / 2, median_value.data());
    // The median absolute deviation of V, scaled to a normal's sigma.
    for (size_t i = 0; i < n; ++i) {
      uint8_t* v = value.data() + i * size_t(w);
      for (int c = 0; c < w; ++c) v[c] = uint8_t(std::abs(int(v[c]) - int(median_value[size_t(c)])));
    }
    SelectKthPerByte(value_rows, w, n / 2, spread.data());
    float* out = value_spread_.ptr<float>(r);
    for (int c = 0; c < w; ++c) out[c] = 1.4826f * spread[size_t(c)];
  }
  cv::cvtColor(background_bgr_, background_hsv_, cv::COLOR_BGR2HSV);
  cv::split(background_hsv_, background_planes_);
  rules_ = std::make_shared<Rules>();  // thresholds are made for the options Segment is given
}

// The per-pixel thresholds one set of options gives this model's background.
// Every comparison of the rule is between bytes (or byte differences) and a
// threshold; an integer x exceeds a real t exactly when x >= Above(t), so each
// threshold becomes a byte the row test compares against (paper §3.1's test
// in 16-byte vectors, where the float rule took 4 lanes and a division).
struct BackgroundModel::Rule {
  double value_threshold, value_noise_k, hue_min_saturation, shadow_min_ratio, shadow_max_ratio;  // the key
  cv::Mat hue_gate;    // 255 where S_bg > hue_min_saturation (the hue can differ), else 0
  cv::Mat value_over;  // |V - V_bg| > this is a value difference (255: none is); from the spread
  cv::Mat shadow_lo;   // V in [shadow_lo, shadow_hi] is a shadow (lo > hi: none)
  cv::Mat shadow_hi;
  cv::Mat shadow_lo_of, shadow_hi_of;  // 1 x 256: the same bounds for each V_bg
  bool Fits(const SegmentationOptions& o) const {
    return value_threshold == o.value_threshold && value_noise_k == o.value_noise_k &&
           hue_min_saturation == o.hue_min_saturation && shadow_min_ratio == o.shadow_min_ratio &&
           shadow_max_ratio == o.shadow_max_ratio;
  }
};

struct BackgroundModel::Rules {
  std::mutex mu;
  std::shared_ptr<const Rule> last;
  // The rule of the background before Follow(): its value bounds (from the
  // spread, which Follow keeps) and shadow bounds per V_bg still hold.
  std::shared_ptr<const Rule> before_follow;
};

namespace {

// The least integer in [0, 255] above t, 256 where none is (t >= 255 or NaN).
int Above(double t) {
  if (!(t < 255)) return 256;
  if (t < 0) return 0;
  return int(std::floor(t)) + 1;
}

// One row of the test (BackgroundModel::ObjectPixels): object if the hue
// differs (both saturated enough), the saturation differs, or the value
// differs beyond the pixel's noise and is not a shadow. Bytes throughout, no
// branches: the compiler makes it 16 pixels a step.
void ObjectPixelRow(const uint8_t* __restrict h, const uint8_t* __restrict s, const uint8_t* __restrict v,
                    const uint8_t* __restrict bh, const uint8_t* __restrict bs, const uint8_t* __restrict bv,
                    const uint8_t* __restrict hue_gate, const uint8_t* __restrict value_over,
                    const uint8_t* __restrict shadow_lo, const uint8_t* __restrict shadow_hi, int width,
                    uint8_t saturated, uint8_t hue_lo, uint8_t hue_hi, uint8_t sat_lo, uint8_t sat_on,
                    uint8_t* __restrict out) {
  for (int c = 0; c < width; ++c) {
    const uint8_t fh = h[c], fs = s[c], fv = v[c], gh = bh[c], gs = bs[c], gv = bv[c];
    const uint8_t dh = uint8_t(std::max(fh, gh) - std::min(fh, gh));  // [0, 179]
    const uint8_t ds = uint8_t(std::max(fs, gs) - std::min(fs, gs));
    const uint8_t dv = uint8_t(std::max(fv, gv) - std::min(fv, gv));
    // Circular hue distance min(dh, 180 - dh) above the threshold: dh in [hue_lo, hue_hi].
    const uint8_t hue = uint8_t(hue_gate[c] & -uint8_t(fs >= saturated) & -uint8_t(dh >= hue_lo) &
                                -uint8_t(dh <= hue_hi));
    const uint8_t sat = uint8_t(sat_on & -uint8_t(ds >= sat_lo));
    const uint8_t value = uint8_t(-uint8_t(dv > value_over[c]));
    const uint8_t shadow = uint8_t(-uint8_t(fv >= shadow_lo[c]) & -uint8_t(fv <= shadow_hi[c]));
    out[c] = uint8_t(hue | sat | (value & ~shadow));
  }
}

}  // namespace

std::shared_ptr<const BackgroundModel::Rule> BackgroundModel::RuleFor(const SegmentationOptions& o) const {
  std::shared_ptr<const Rule> before;
  {
    std::lock_guard<std::mutex> lock(rules_->mu);
    if (rules_->last && rules_->last->Fits(o)) return rules_->last;
    before = rules_->before_follow;
  }
  auto rule = std::make_shared<Rule>();
  rule->value_threshold = o.value_threshold;
  rule->value_noise_k = o.value_noise_k;
  rule->hue_min_saturation = o.hue_min_saturation;
  rule->shadow_min_ratio = o.shadow_min_ratio;
  rule->shadow_max_ratio = o.shadow_max_ratio;
  // S_bg > hue_min_saturation.
  const int saturated = Above(o.hue_min_saturation);
  // (No cv::Mat::zeros: its expression's first use from several cameras'
  // threads at once is a race inside OpenCV.)
  if (saturated < 256) {
    cv::compare(background_planes_[1], saturated, rule->hue_gate, cv::CMP_GE);
  } else {
    rule->hue_gate.create(size(), CV_8UC1);
    rule->hue_gate.setTo(cv::Scalar(0));
  }
  // |dv| > max(value_threshold, k * spread) in floats, as the rule states it;
  // Check() keeps the threshold >= 0, so the float bound is >= 0 or NaN.
  if (before && before->value_threshold == o.value_threshold && before->value_noise_k == o.value_noise_k) {
    rule->value_over = before->value_over;
  } else {
    const float vt = float(o.value_threshold), vk = float(o.value_noise_k);
    rule->value_over.create(size(), CV_8UC1);
    for (int r = 0; r < size().height; ++r) {
      const float* spread = value_spread_.ptr<float>(r);
      uint8_t* over = rule->value_over.ptr<uint8_t>(r);
      for (int c = 0; c < size().width; ++c) over[c] = uint8_t(Above(std::max(vt, vk * spread[c])) - 1);  // [0, 255]
    }
  }
  // A shadow: V < V_bg and the float ratio V / V_bg in [min, max]. The ratio
  // grows with V (a division by a fixed divisor, correctly rounded), so the
  // shadow's values for each V_bg are one interval, found here value by value.
  if (before && before->shadow_min_ratio == o.shadow_min_ratio && before->shadow_max_ratio == o.shadow_max_ratio) {
    rule->shadow_lo_of = before->shadow_lo_of;
    rule->shadow_hi_of = before->shadow_hi_of;
  } else {
    rule->shadow_lo_of.create(1, 256, CV_8UC1);
    rule->shadow_hi_of.create(1, 256, CV_8UC1);
    const float smin = float(o.shadow_min_ratio), smax = float(o.shadow_max_ratio);
    for (int gv = 0; gv < 256; ++gv) {
      int first = 255, last = 0;  // none: first > last
      for (int fv = 0; fv < gv; ++fv) {
        const float ratio = float(fv) / float(gv);
        if (ratio >= smin && ratio <= smax) {
          first = std::min(first, fv);
          last = fv;
        }
      }
      rule->shadow_lo_of.at<uint8_t>(gv) = uint8_t(first);
      rule->shadow_hi_of.at<uint8_t>(gv) = uint8_t(last);
    }
  }
  cv::LUT(background_planes_[2], rule->shadow_lo_of, rule->shadow_lo);
  cv::LUT(background_planes_[2], rule->shadow_hi_of, rule->shadow_hi);
  std::lock_guard<std::mutex> lock(rules_->mu);
  rules_->last = rule;
  return rule;
}

cv::Mat BackgroundModel::ObjectPixels(const cv::Mat& frame_bgr, const SegmentationOptions& o) const {
  if (empty()) throw std::invalid_argument("BackgroundModel: not learnt");
  if (frame_bgr.size() != size() || frame_bgr.type() != CV_8UC3)
    throw std::invalid_argument("BackgroundModel: frame is " + std::to_string(frame_bgr.cols) +
                                "x" + std::to_string(frame_bgr.rows) + ", model is " +
                                std::to_string(size().width) + "x" + std::to_string(size().height));
  o.Check();
  const std::shared_ptr<const Rule> rule = RuleFor(o);
  cv::Mat hsv;
  cv::cvtColor(frame_bgr, hsv, cv::COLOR_BGR2HSV);
  // One plane per channel, so that the test runs over contiguous bytes.
  cv::Mat planes[3];
  cv::split(hsv, planes);
  // The options' thresholds that are one for the whole map.
  const int saturated = Above(o.hue_min_saturation);  // S > hue_min_saturation (256: the gate is shut)
  const int hue_lo = std::min(Above(o.hue_threshold), 91);  // 91: no distance in [0, 90] is above
  const int sat_lo = Above(o.saturation_threshold);
  cv::Mat map(size(), CV_8UC1);
  for (int r = 0; r < size().height; ++r)
    ObjectPixelRow(planes[0].ptr<uint8_t>(r), planes[1].ptr<uint8_t>(r), planes[2].ptr<uint8_t>(r),
                   background_planes_[0].ptr<uint8_t>(r), background_planes_[1].ptr<uint8_t>(r),
                   background_planes_[2].ptr<uint8_t>(r), rule->hue_gate.ptr<uint8_t>(r),
                   rule->value_over.ptr<uint8_t>(r), rule->shadow_lo.ptr<uint8_t>(r), rule->shadow_hi.ptr<uint8_t>(r),
                   size().width, uint8_t(std::min(saturated, 255)), uint8_t(hue_lo), uint8_t(180 - hue_lo),
                   uint8_t(std::min(sat_lo, 255)), uint8_t(sat_lo < 256 ? 255 : 0), map.ptr<uint8_t>(r));
  return map;
}

cv::Mat BackgroundModel::Segment(const cv::Mat& frame_bgr, const SegmentationOptions& o) const {
  cv::Mat map = ObjectPixels(frame_bgr, o);
  CleanObjectPixelMap(map, o);
  return map;
}

void BackgroundModel::Follow(const cv::Mat& frame_bgr, const cv::Mat& map, double rate) {
  if (empty()) throw std::invalid_argument("BackgroundModel: not learnt");
  if (frame_bgr.size() != size() || frame_bgr.type() != CV_8UC3 || map.size() != size() || map.type() != CV_8UC1)
    throw std::invalid_argument("BackgroundModel::Follow: frame or map of another size or type than the model");
  if (!(rate >= 0 && rate <= 1)) throw std::invalid_argument("BackgroundModel::Follow: rate must be in [0, 1]");
  cv::Mat background;
  cv::compare(map, 0, background, cv::CMP_EQ);
  // Too little background visible to measure the light: keep the model.
  if (cv::countNonZero(background) < int(0.05 * double(map.total()))) return;
  if (background_f_.empty()) background_bgr_.convertTo(background_f_, CV_32FC3);
  cv::Mat frame_f;
  frame_bgr.convertTo(frame_f, CV_32FC3);
  const cv::Scalar seen = cv::mean(frame_f, background), model = cv::mean(background_f_, background);
  cv::Scalar gain;
  for (int k = 0; k < 3; ++k) gain[k] = model[k] > 1 ? std::clamp(seen[k] / model[k], 0.5, 2.0) : 1.0;
  cv::multiply(background_f_, gain, background_f_);
  cv::accumulateWeighted(frame_f, background_f_, rate, background);
  background_f_.convertTo(background_bgr_, CV_8UC3);
  cv::cvtColor(background_bgr_, background_hsv_, cv::COLOR_BGR2HSV);
  cv::split(background_hsv_, background_planes_);
  // The background changed: the thresholds made from it are made again.
  std::shared_ptr<const Rule> last;
  {
    std::lock_guard<std::mutex> lock(rules_->mu);
    last = rules_->last ? rules_->last : rules_->before_follow;
  }
  rules_ = std::make_shared<Rules>();
  rules_->before_follow = last;
}

void CleanObjectPixelMap(cv::Mat& map, const SegmentationOptions& o) {
  // Only the object pixels' neighbourhood can change: an opening and a closing
  // reach at most their radii beyond the object pixels, and every contour lies
  // within. A person fills a tenth of an HD camera's map; the whole map's
  // morphology and contour search were a third of its segmentation time.
  const cv::Rect box = cv::boundingRect(map);  // of the non-zero pixels
  if (box.empty()) return;  // nothing to clean, and nothing is drawn
  const int margin = std::max(0, o.open_radius) + std::max(0, o.close_radius) + 2;
  const cv::Rect region =
      cv::Rect(box.x - margin, box.y - margin, box.width + 2 * margin, box.height + 2 * margin) &
      cv::Rect(0, 0, map.cols, map.rows);
  CleanObjectPixelMapIn(map, region, o);
}

void CleanObjectPixelMapIn(cv::Mat& map, const cv::Rect& region, const SegmentationOptions& o) {
  // The component and hole bounds are fractions of the whole map.
  const double total = double(map.total());
  cv::Mat part = map(region);
  if (o.open_radius > 0) {
    const int k = 2 * o.open_radius + 1;
    cv::morphologyEx(part, part, cv::MORPH_OPEN,
                     cv::getStructuringElement(cv::MORPH_ELLIPSE, {k, k}));
  }
  if (o.close_radius > 0) {
    const int k = 2 * o.close_radius + 1;
    cv::morphologyEx(part, part, cv::MORPH_CLOSE,
                     cv::getStructuringElement(cv::MORPH_ELLIPSE, {k, k}));
  }
  std::vector<std::vector<cv::Point>> contours;
  std::vector<cv::Vec4i> hierarchy;
  cv::findContours(part, contours, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_NONE);
  double largest = 0;
  for (int i = 0; i >= 0 && !contours.empty(); i = hierarchy[i][0])
    largest = std::max(largest, cv::contourArea(contours[i]));
  const double min_area =
      std::max(o.min_component_fraction * total, o.min_component_ratio * largest);
  const double max_hole = o.max_hole_fraction * total;
  part.setTo(0);
  if (contours.empty()) return;
  // With RETR_CCOMP, top-level contours are outer boundaries of components and
  // their children are the boundaries of holes.
  for (int i = 0; i >= 0; i = hierarchy[i][0]) {
    if (cv::contourArea(contours[i]) < min_area) continue;
    cv::drawContours(part, contours, i, 255, cv::FILLED);
    for (int h = hierarchy[i][2]; h >= 0; h = hierarchy[h][0]) {
      if (cv::contourArea(contours[h]) < max_hole) continue;
      cv::drawContours(part, contours, h, 0, cv::FILLED);
      cv::drawContours(part, contours, h, 255, 1);  // the hole's rim is object
    }
  }
}

}  // namespace hullpipe
