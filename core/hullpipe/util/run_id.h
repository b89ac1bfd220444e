// Run ids (docs/reliability.md, "run id"): 64-bit tokens that every node of one
// run carries (--run-id), so samples of another run on the same DDS domain can
// be told apart. Written as 16 hex digits. And the domain ids themselves
// (--domain), whose bound every node and the launcher share.
#pragma once

#include <cstdint>
#include <cstdio>
#include <optional>
#include <random>
#include <string>

namespace hullpipe {

/// The largest DDS domain id Cyclone takes (the RTPS port formula's limit):
/// --domain is 0..kMaxDomainId in every node and the launcher.
constexpr uint32_t kMaxDomainId = 232;

/// The 16 hex digits --run-id takes.
inline std::string RunIdText(uint64_t run_id) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(run_id));
  return buf;
}

/// Parses 1 to 16 hex digits, not all zero; nullopt otherwise.
inline std::optional<uint64_t> ParseRunId(const std::string& text) {
  if (text.empty() || text.size() > 16) return std::nullopt;
  uint64_t id = 0;
  for (const char c : text) {
    const int d = c >= '0' && c <= '9'   ? c - '0'
                  : c >= 'a' && c <= 'f' ? c - 'a' + 10
                  : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                         : -1;
    if (d < 0) return std::nullopt;
    id = id << 4 | uint64_t(d);
  }
  if (id == 0) return std::nullopt;
  return id;
}

/// A random non-zero run id.
inline uint64_t NewRunId() {
  std::random_device rd;
  uint64_t id = 0;
  while (id == 0) id = (uint64_t(rd()) << 32) ^ uint64_t(rd());
  return id;
}

}  // namespace hullpipe
