// Reading a scene file's sections (scene_config.h): the helpers every element
// kind's reader shares, so each section names its keys once and refuses
// misspelt ones the same way. Included by the scenes module's sources only.
#pragma once

#include <functional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <yaml-cpp/yaml.h>

#include "hullpipe/util/yaml_keys.h"

namespace hullpipe::scene_yaml {

/// n[key] as 3 numbers, or `fallback` when absent. Throws std::runtime_error
/// naming the file and key when it is not 3 numbers (YAML::Exception when not
/// numbers: LoadSceneConfig prefixes the file).
inline Eigen::Vector3d Vec3(const YAML::Node& n, const std::string& path, const char* key,
                            const Eigen::Vector3d& fallback) {
  if (!n[key]) return fallback;
  const auto v = n[key].as<std::vector<double>>();
  if (v.size() != 3) throw std::runtime_error(path + ": '" + key + "' must have 3 numbers");
  return {v[0], v[1], v[2]};
}

/// A section must be a map with only the keys this build reads (a misspelt key
/// would otherwise be ignored and its default used without a word) and the ones
/// it cannot do without. Throws std::runtime_error naming the file and the key
/// (as "section.key").
/// `known` may be made at run time (the top level adds the registered kinds).
inline void Keys(const YAML::Node& n, const std::string& path, const std::string& section,
                 const std::vector<std::string>& known, const std::vector<const char*>& required = {}) {
  const std::string where = section.empty() ? "" : section + ".";
  if (!n.IsMap()) throw std::runtime_error(path + ": '" + section + "' must be a map of keys");
  if (const auto key = FirstUnknownKey(n, known))
    throw std::runtime_error(path + ": unknown key '" + where + *key + "' (known: " + KeyList(known) + ")");
  for (const char* k : required)
    if (!n[k]) throw std::runtime_error(path + ": key '" + where + k + "' is missing");
}

/// Whether a Section's key must be present.
enum class Need { kOptional, kRequired };

/// One section read field by field, each key named once: every Field and Vec
/// binds a key to where its value goes; Read() first refuses a key no field
/// names and a required key that is missing (as Keys: misspelt keys are named
/// before any value is read), then reads each key present into its field.
/// Errors: std::runtime_error naming the file and "section.key"; a value of the
/// wrong type, YAML::Exception (LoadSceneConfig prefixes the file).
class Section {
 public:
  Section(const YAML::Node& n, std::string path, std::string name)
      : n_(n), path_(std::move(path)), name_(std::move(name)) {}
  /// *out = the key's value, when present.
  template <typename T>
  Section& Field(const char* key, T* out, Need need = Need::kOptional) {
    Bind(key, need, [this, key, out] { *out = n_[key].template as<T>(); });
    return *this;
  }
  /// *out = the key's 3 numbers, when present.
  Section& Vec(const char* key, Eigen::Vector3d* out, Need need = Need::kOptional) {
    Bind(key, need, [this, key, out] { *out = Vec3(n_, path_, key, *out); });
    return *this;
  }
  /// *out = the value of the word the key gives, when present; another word
  /// throws std::runtime_error "'section.key' must be a, b or c, not w" (the
  /// words as `said`, default every word in order).
  template <typename T>
  Section& Choice(const char* key, T* out, std::vector<std::pair<std::string, T>> words, std::string said = "",
                  Need need = Need::kOptional) {
    if (said.empty())
      for (size_t i = 0; i < words.size(); ++i)
        said += (i == 0 ? "" : i + 1 == words.size() ? " or " : ", ") + words[i].first;
    Bind(key, need, [this, key, out, words = std::move(words), said = std::move(said)] {
      const std::string w = n_[key].template as<std::string>();
      for (const auto& [word, value] : words)
        if (word == w) {
          *out = value;
          return;
        }
      throw std::runtime_error(path_ + ": '" + Where() + key + "' must be " + said + ", not " + w);
    });
    return *this;
  }
  /// Whether the section gives `key` (for settings that exclude each other).
  bool Has(const char* key) const { return bool(n_[key]); }
  /// "section." ("" at the top level).
  std::string Where() const { return name_.empty() ? "" : name_ + "."; }
  void Read() const {
    Keys(n_, path_, name_, known_, required_);
    for (size_t i = 0; i < known_.size(); ++i)
      if (n_[known_[i]]) readers_[i]();
  }

 private:
  void Bind(const char* key, Need need, std::function<void()> read) {
    known_.push_back(key);
    if (need == Need::kRequired) required_.push_back(key);
    readers_.push_back(std::move(read));
  }
  YAML::Node n_;
  std::string path_, name_;
  std::vector<std::string> known_;
  std::vector<const char*> required_;
  std::vector<std::function<void()>> readers_;
};

}  // namespace hullpipe::scene_yaml
