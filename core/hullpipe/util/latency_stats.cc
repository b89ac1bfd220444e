#include "hullpipe/util/latency_stats.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace hullpipe {

void SampleStats::Add(double v) {
  if (samples_.size() < capacity_) {
    samples_.push_back(v);
  } else {
    samples_[total_ % capacity_] = v;
  }
  ++total_;
}

double SampleStats::Percentile(double p) const {
  if (samples_.empty()) return 0;
  std::vector<double> s = samples_;
  const double rank = std::clamp(p, 0.0, 100.0) / 100.0 * double(s.size());
  size_t k = size_t(std::ceil(rank));
  k = std::clamp<size_t>(k, 1, s.size()) - 1;
  std::nth_element(s.begin(), s.begin() + long(k), s.end());
  return s[k];
}

double SampleStats::Mean() const {
  if (samples_.empty()) return 0;
  return std::accumulate(samples_.begin(), samples_.end(), 0.0) / double(samples_.size());
}

}  // namespace hullpipe
