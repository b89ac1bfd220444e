// Which planes of a sweep lie in front of or behind an eye depth, in constant
// time: the CPU sweep (plane_sweep.h, paper §3.3) asks it four times a ray, to
// clip the ray's planes to its part in the hull box and to its block's bounds.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace hullpipe {

// std::lower_bound and std::upper_bound over a sorted list of plane depths
// (metres along the eye's z axis, non-decreasing: SweepPlaneDepths' uniform or
// inverse-depth planes, or any others), as indices, exactly as those give them,
// for any double: -inf, +inf and NaN included (NaN: FirstNotBelow 0,
// FirstAbove size(), as the comparisons a < NaN and NaN < a are false).
//
// The depths' range is cut into buckets of equal width, four a plane; a bucket
// holds the count of planes in the buckets before it. A query takes its
// bucket's count and steps over the planes in its own bucket that it passes:
// none or one where no gap between planes is under a quarter of the mean gap
// (uniform spacing, and inverse-depth spacing up to far / near = 4, whose
// least gap is the mean times near / far). Where planes crowd a bucket the
// steps stop after kMaxSteps and a binary search finishes.
// Exact whatever the spacing: the bucket of a depth never decreases with the
// depth (a subtraction and a multiplication, both monotone when rounded), so
// every plane counted before a query's bucket is below the query's depth.
class PlaneIndex {
 public:
  /// depths: non-decreasing and finite (a sweep's planes), possibly empty; held
  /// by reference, so it must outlive the index and not change. Throws
  /// std::invalid_argument when the list is not sorted or holds a NaN or an
  /// infinity.
  explicit PlaneIndex(const std::vector<double>& depths);

  /// The first index i with depths[i] >= x (std::lower_bound's), or size().
  size_t FirstNotBelow(double x) const { return Find<false>(x); }
  /// The first index i with depths[i] > x (std::upper_bound's), or size().
  size_t FirstAbove(double x) const { return Find<true>(x); }
  /// The plane depths indexed (the list given, not a copy), and their count.
  const std::vector<double>& depths() const { return depths_; }
  size_t size() const { return depths_.size(); }

 private:
  // Steps a query takes through its bucket before a binary search takes over.
  static constexpr int kMaxSteps = 4;
  // The bucket of a depth in [front_, back_] (the product is at most
  // last_bucket_ + 1 but for rounding). Inline: a ray asks four times.
  int64_t Bucket(double x) const {
    return std::min(int64_t((x - front_) * buckets_per_metre_), last_bucket_);
  }
  // kAbove: upper bound (passes planes equal to x), else lower bound.
  template <bool kAbove>
  size_t Find(double x) const {
    const size_t n = depths_.size();
    // NaN passes neither comparison: lower bound 0, upper bound n.
    if (!(x >= front_)) return kAbove && x != x ? n : 0;
    if (!(x <= back_)) return n;
    const double* a = depths_.data();
    size_t i = before_[size_t(Bucket(x))];
    for (int s = 0; s < kMaxSteps; ++s, ++i)
      if (i == n || !(kAbove ? a[i] <= x : a[i] < x)) return i;
    if (i == n) return n;
    // Crowded: a branch-free binary search over [i, n).
    const double* base = a + i;
    for (size_t m = n - i; m > 1; m -= m / 2)
      base = (kAbove ? base[m / 2] <= x : base[m / 2] < x) ? base + m / 2 : base;
    return size_t(base - a) + size_t(kAbove ? *base <= x : *base < x);
  }

  const std::vector<double>& depths_;
  double front_ = 0, back_ = 0, buckets_per_metre_ = 0;
  int64_t last_bucket_ = 0;
  // before_[b]: the planes whose bucket is below b (the count, an index).
  std::vector<uint32_t> before_;
};

}  // namespace hullpipe
