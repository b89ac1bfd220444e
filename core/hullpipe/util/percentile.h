// The one percentile rule of hullpipe's reports, benchmarks and evaluations.
#pragma once

#include <vector>

namespace hullpipe {

/// Nearest-rank percentile: the ceil(p/100 * n)-th smallest of `values` (p in
/// [0, 100], clamped; p = 0 gives the smallest). 0 when `values` is empty.
/// O(n) (nth_element on the copy it takes).
double Percentile(std::vector<double> values, double p);

/// The upper median, the (n/2)-th smallest counting from 0 (for odd n the
/// median); 0 when empty. The benchmarks' "median of repeats".
double Median(std::vector<double> values);

}  // namespace hullpipe
