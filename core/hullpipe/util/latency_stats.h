// Running statistics for node reports: rates and latency percentiles.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace hullpipe {

/// Collects samples (e.g. latencies in ms) and reports percentiles. Keeps at
/// most `capacity` most recent samples (a ring), so memory stays bounded.
class SampleStats {
 public:
  explicit SampleStats(size_t capacity = 100000) : capacity_(capacity) {}
  void Add(double value);
  size_t count() const { return total_; }
  /// Percentile p in [0, 100] by nearest rank over the kept samples; 0 if none.
  double Percentile(double p) const;
  double Mean() const;

 private:
  size_t capacity_;
  size_t total_ = 0;
  std::vector<double> samples_;
};

}  // namespace hullpipe
