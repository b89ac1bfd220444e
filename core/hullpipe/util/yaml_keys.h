// The one check of a YAML map's keys against those a reader knows, for every
// file hullpipe reads as YAML (rig files, scene files, launch descriptions): a
// misspelt key must be refused, not silently become a default. Each reader
// throws its own error naming its file and section.
#pragma once

#include <algorithm>
#include <initializer_list>
#include <optional>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

namespace hullpipe {

/// The first key of YAML map `map` that is not in `known` ("?" for a key that
/// is not a scalar), or nullopt when every key is known.
inline std::optional<std::string> FirstUnknownKey(const YAML::Node& map, std::initializer_list<const char*> known) {
  for (const auto& kv : map) {
    const std::string key = kv.first.as<std::string>("?");
    if (std::none_of(known.begin(), known.end(), [&](const char* k) { return key == k; })) return key;
  }
  return std::nullopt;
}

/// "a, b, c": the known keys, for an error message.
inline std::string KeyList(std::initializer_list<const char*> known) {
  std::string list;
  for (const char* k : known) list += (list.empty() ? "" : ", ") + std::string(k);
  return list;
}

/// FirstUnknownKey for a list of keys made at run time (a registry's).
inline std::optional<std::string> FirstUnknownKey(const YAML::Node& map, const std::vector<std::string>& known) {
  for (const auto& kv : map) {
    const std::string key = kv.first.as<std::string>("?");
    if (std::find(known.begin(), known.end(), key) == known.end()) return key;
  }
  return std::nullopt;
}

/// KeyList for a list of keys made at run time.
inline std::string KeyList(const std::vector<std::string>& known) {
  std::string list;
  for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
  return list;
}

}  // namespace hullpipe
