// How much a test's timing bounds stretch in this run (shared by the core's
// tests and the multi-process ones).
#pragma once

#include <cstdlib>

namespace hullpipe::test {

/// How much longer than the specification a timing bound may be in this run:
/// HULLPIPE_TEST_TIME_SCALE (scripts/sanitize.sh sets 4 for ThreadSanitizer,
/// which slows every process 5-15 fold), else 1. The main suite checks the
/// specified bounds; the sanitizer stage looks for races and leaks.
inline double TimeScale() {
  const char* s = std::getenv("HULLPIPE_TEST_TIME_SCALE");
  const double v = s ? std::atof(s) : 1.0;
  return v >= 1.0 && v <= 100.0 ? v : 1.0;
}

}  // namespace hullpipe::test
