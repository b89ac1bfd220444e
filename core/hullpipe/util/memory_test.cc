#include "hullpipe/util/memory.h"
#include "hullpipe/util/sanitized.h"

#include <sys/resource.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace hullpipe {
namespace {

long MinorFaults() {
  rusage r{};
  getrusage(RUSAGE_SELF, &r);
  return r.ru_minflt;
}

// Minor page faults of allocating `bytes`, writing every page and freeing it,
// the second time round (the first may grow the heap).
long FaultsOfASecondRound(size_t bytes) {
  long faults = 0;
  for (int round = 0; round < 2; ++round) {
    const long before = MinorFaults();
    char* p = static_cast<char*>(std::malloc(bytes));
    if (!p) return -1;
    for (size_t i = 0; i < bytes; i += 4096) p[i] = char(i);
    asm volatile("" : : "r"(p) : "memory");  // the writes happen
    std::free(p);
    faults = MinorFaults() - before;
  }
  return faults;
}

// A frameset's 4 MiB scratch block, allocated and freed every frameset: with
// glibc's default policy each round faults its 1,024 pages in afresh (the
// control); once KeepFreedMemory has run, the second round faults none of them
// (a few for the allocator's own bookkeeping at most).
TEST(Memory, AFramesetsFreedBlockIsKeptForTheNext) {
#if !defined(__GLIBC__)
  GTEST_SKIP() << "not glibc";
#else
#ifdef HULLPIPE_SANITIZED
  GTEST_SKIP() << "a sanitizer's allocator replaces malloc";
#endif
  // With transparent huge pages always on, a fresh 4 MiB mapping faults in a
  // few 2 MiB pages, not 1,024: the control would not tell.
  {
    std::ifstream thp("/sys/kernel/mm/transparent_hugepage/enabled");
    std::string mode((std::istreambuf_iterator<char>(thp)), std::istreambuf_iterator<char>());
    if (mode.find("[always]") != std::string::npos) GTEST_SKIP() << "transparent huge pages always on";
  }
  constexpr size_t kBytes = 4 << 20;
  mallopt(M_MMAP_THRESHOLD, 128 << 10);  // glibc's defaults
  mallopt(M_TRIM_THRESHOLD, 128 << 10);
  EXPECT_GE(FaultsOfASecondRound(kBytes), 900) << "the control: a freed block's pages are given back";
  KeepFreedMemory();
  EXPECT_LE(FaultsOfASecondRound(kBytes), 16);
#endif
}

}  // namespace
}  // namespace hullpipe
