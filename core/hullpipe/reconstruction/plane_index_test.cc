// PlaneIndex (plane_index.h) against std::lower_bound and std::upper_bound, the
// exact answers, on the spacings a sweep makes and on hard ones: planes crowded
// into one bucket, repeated depths, a range a few floats wide, large depths,
// and queries on, just beside and between every plane, outside the range,
// infinite and NaN.
#include "hullpipe/reconstruction/plane_index.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

namespace hullpipe {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Checks every query of interest on `depths`; `what` names the case in a failure.
void ExpectExact(const std::vector<double>& depths, const std::string& what) {
  const PlaneIndex index(depths);
  ASSERT_EQ(index.size(), depths.size()) << what;
  std::vector<double> queries = {-kInf, kInf, -0.0, 0.0, -1e300, 1e300, std::numeric_limits<double>::denorm_min()};
  for (size_t i = 0; i < depths.size(); ++i) {
    const double d = depths[i];
    queries.insert(queries.end(), {d, std::nextafter(d, -kInf), std::nextafter(d, kInf)});
    if (i > 0) queries.push_back(0.5 * (depths[i - 1] + d));
  }
  if (!depths.empty()) {
    std::mt19937_64 rng(7);
    const double lo = depths.front(), hi = depths.back(), pad = 0.1 * (hi - lo) + 1e-9;
    std::uniform_real_distribution<double> u(lo - pad, hi + pad);
    for (int i = 0; i < 2000; ++i) queries.push_back(u(rng));
  }
  for (const double x : queries) {
    const size_t lower = size_t(std::lower_bound(depths.begin(), depths.end(), x) - depths.begin());
    const size_t upper = size_t(std::upper_bound(depths.begin(), depths.end(), x) - depths.begin());
    ASSERT_EQ(index.FirstNotBelow(x), lower) << what << ": lower bound of " << x;
    ASSERT_EQ(index.FirstAbove(x), upper) << what << ": upper bound of " << x;
  }
  // NaN: no plane is below it nor above it (a < NaN and NaN < a are false).
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(index.FirstNotBelow(nan), 0u) << what;
  EXPECT_EQ(index.FirstAbove(nan), depths.size()) << what;
}

std::vector<double> Spaced(int n, double near, double far, bool inverse) {
  std::vector<double> d(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) {
    const double s = double(k) / (n - 1);
    d[size_t(k)] = inverse ? 1.0 / (1.0 / near + s * (1.0 / far - 1.0 / near)) : near + s * (far - near);
  }
  return d;
}

TEST(PlaneIndex, SweepSpacingsGiveTheExactBounds) {
  for (const int n : {2, 3, 48, 100, 4096})
    for (const bool inverse : {false, true})
      for (const auto& [near, far] : {std::pair{0.5, 3.0}, {1.0, 1.1}, {0.01, 100.0}, {2.0, 2.0 + 1e-9}})
        ExpectExact(Spaced(n, near, far, inverse), std::to_string(n) + (inverse ? " inverse " : " uniform ") +
                                                       std::to_string(near) + ".." + std::to_string(far));
}

TEST(PlaneIndex, HardSpacingsGiveTheExactBounds) {
  ExpectExact({}, "no planes");
  ExpectExact({1.5}, "one plane");
  ExpectExact({1.5, 1.5}, "two planes at one depth");
  ExpectExact({1, 1, 1, 2, 2, 3, 3, 3, 3}, "repeated depths");
  // All but one plane crowded into the first bucket: steps, then the binary search.
  std::vector<double> crowded;
  for (int k = 0; k < 200; ++k) crowded.push_back(1.0 + k * 1e-7);
  crowded.push_back(5.0);
  ExpectExact(crowded, "crowded into one bucket");
  // ... and into the last (the clamped bucket of the back plane).
  std::vector<double> crowded_back = {1.0};
  for (int k = 0; k < 200; ++k) crowded_back.push_back(5.0 - (199 - k) * 1e-7);
  ExpectExact(crowded_back, "crowded into the last bucket");
  // A range a few floats wide, one of denormals, and large depths.
  const double a = 1.0;
  ExpectExact({a, std::nextafter(a, 2.0), std::nextafter(std::nextafter(a, 2.0), 2.0)}, "adjacent doubles");
  const double tiny = std::numeric_limits<double>::denorm_min();
  ExpectExact({0.0, tiny, 2 * tiny, 5 * tiny}, "denormal depths");
  ExpectExact(Spaced(64, 1e6, 1e6 + 1, false), "large depths");
  ExpectExact({-3.0, -1.0, 0.0, 2.0}, "negative depths");
  std::mt19937_64 rng(11);
  std::exponential_distribution<double> gap(1.0);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<double> d = {0.2};
    for (int k = 0; k < 150; ++k) d.push_back(d.back() + std::pow(gap(rng), 4.0) * 1e-3);
    ExpectExact(d, "random gaps " + std::to_string(trial));
  }
}

TEST(PlaneIndex, UnsortedOrNonFiniteDepthsAreRefused) {
  for (const std::vector<double>& bad :
       {std::vector<double>{1.0, 0.5}, {1.0, std::numeric_limits<double>::quiet_NaN()}, {1.0, kInf}, {-kInf, 1.0},
        {-1e308, 1e308}}) {
    EXPECT_THROW(PlaneIndex{bad}, std::invalid_argument);
  }
  // Positive control: the same lists made valid are taken.
  EXPECT_NO_THROW(PlaneIndex(std::vector<double>{0.5, 1.0}));
  EXPECT_NO_THROW(PlaneIndex(std::vector<double>{-1e307, 1e307}));
}

}  // namespace
}  // namespace hullpipe
