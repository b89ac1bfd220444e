#include "hullpipe/util/percentile.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace hullpipe {

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  const double rank = std::clamp(p, 0.0, 100.0) / 100.0 * double(v.size());
  const size_t k = std::clamp<size_t>(size_t(std::ceil(rank)), 1, v.size()) - 1;
  std::nth_element(v.begin(), v.begin() + long(k), v.end());
  return v[k];
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  const size_t k = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + long(k), v.end());
  return v[k];
}

}  // namespace hullpipe
