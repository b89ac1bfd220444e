#include "hullpipe/util/latency_stats.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "hullpipe/util/percentile.h"

namespace hullpipe {

void SampleStats::Add(double v) {
  if (samples_.size() < capacity_) {
    samples_.push_back(v);
  } else {
    samples_[total_ % capacity_] = v;
  }
  ++total_;
}

double SampleStats::Percentile(double p) const { return hullpipe::Percentile(samples_, p); }

double SampleStats::Mean() const {
  if (samples_.empty()) return 0;
  return std::accumulate(samples_.begin(), samples_.end(), 0.0) / double(samples_.size());
}

}  // namespace hullpipe
