#include "hullpipe/ros2/ros2_topics.h"

#include <cctype>
#include <stdexcept>

namespace hullpipe::ros2 {

std::string DdsTopicOf(const std::string& name) {
  auto bad = [&](const std::string& why) {
    return std::invalid_argument("ROS 2 topic '" + name.substr(0, 80) + "': " + why);
  };
  if (name.size() < 2 || name[0] != '/') throw bad("must be absolute (start with '/')");
  if (name.size() > 200) throw bad("longer than 200 characters");
  if (name.back() == '/') throw bad("must not end with '/'");
  bool token_start = true;
  for (size_t i = 1; i < name.size(); ++i) {
    const char c = name[i];
    if (c == '/') {
      if (token_start) throw bad("has an empty token ('//')");
      token_start = true;
      continue;
    }
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) throw bad("only letters, digits, '_' and '/'");
    if (token_start && std::isdigit(static_cast<unsigned char>(c))) throw bad("a token must not start with a digit");
    token_start = false;
  }
  return "rt" + name;
}

}  // namespace hullpipe::ros2
