// HULLPIPE_SANITIZED: defined where a sanitizer's runtime (ASan, TSan, MSan)
// replaces the C library's allocator and process limits, so code and tests
// that rely on glibc's malloc or on rlimits (docs/reliability.md) can tell.
#pragma once

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define HULLPIPE_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define HULLPIPE_SANITIZED 1
#endif
#endif
