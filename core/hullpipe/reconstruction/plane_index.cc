#include "hullpipe/reconstruction/plane_index.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace hullpipe {

PlaneIndex::PlaneIndex(const std::vector<double>& depths) : depths_(depths) {
  const size_t n = depths.size();
  if (n >= std::numeric_limits<uint32_t>::max() / 4)
    throw std::invalid_argument("PlaneIndex: " + std::to_string(n) + " plane depths are too many");
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(depths[i]))
      throw std::invalid_argument("PlaneIndex: plane depth " + std::to_string(i) + " is not finite");
    if (i > 0 && depths[i] < depths[i - 1])
      throw std::invalid_argument("PlaneIndex: plane depths are not sorted (depth " + std::to_string(i) +
                                  " is below the one before)");
  }
  if (n == 0) {
    // Every finite query is below front_ (index 0) or, +inf, above back_ (n = 0).
    front_ = std::numeric_limits<double>::infinity();
    back_ = -front_;
    before_.assign(1, 0);
    return;
  }
  front_ = depths.front();
  back_ = depths.back();
  last_bucket_ = int64_t(4 * n) - 1;
  if (!std::isfinite(back_ - front_))
    throw std::invalid_argument("PlaneIndex: plane depths span more than a double holds");
  // One bucket for planes all at one depth, or a range too narrow to divide.
  const double per_metre = double(last_bucket_ + 1) / (back_ - front_);
  buckets_per_metre_ = std::isfinite(per_metre) ? per_metre : 0;
  before_.assign(size_t(last_bucket_) + 1, 0);
  // Count the planes of each bucket, then sum them into counts before it.
  for (const double d : depths)
    if (Bucket(d) < last_bucket_) ++before_[size_t(Bucket(d)) + 1];
  for (size_t b = 1; b < before_.size(); ++b) before_[b] += before_[b - 1];
}

}  // namespace hullpipe
