#include "hullpipe/launch/description.h"

#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "hullpipe/util/yaml_keys.h"

namespace hullpipe::launch {
namespace {

// The pipeline's nodes, and the processes that run beside it (the Foxglove
// bridge, the ROS 2 bridge: docs/recording.md, docs/ros2.md).
const char* const kNodeExecs[] = {"render_node", "recon_node", "sim_node", "capture_node", "hullpipe_bridge",
                                  "hullpipe_ros2"};

bool PlainName(const std::string& s) {
  if (s.empty() || s.size() > 64) return false;
  for (char c : s)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-'))
      return false;
  return true;
}

// A host ssh can be given as its destination and nothing else: a name or
// address ([user@]host, IPv6 in brackets or bare), never an option ('-...')
// nor anything a shell or ssh would read further (spaces, quotes, '$', ';').
bool PlainHost(const std::string& h) {
  if (h.empty() || h.size() > 255 || h.front() == '-') return false;
  for (char c : h)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '-' ||
          c == '_' || c == ':' || c == '@' || c == '[' || c == ']' || c == '%'))
      return false;
  return true;
}

std::string Substitute(std::string s, const std::map<std::string, std::string>& vars) {
  for (const auto& [k, v] : vars) {
    const std::string key = "${" + k + "}";
    for (size_t p = s.find(key); p != std::string::npos; p = s.find(key, p + v.size())) s.replace(p, key.size(), v);
  }
  return s;
}

NodeSpec ParseNode(const YAML::Node& n) {
  if (!n.IsMap()) throw std::runtime_error("each entry of 'nodes' must be a map");
  const std::initializer_list<const char*> kNodeKeys = {"name", "exec", "host", "args", "start_delay", "nice"};
  const std::string label = n["name"] && n["name"].IsScalar() ? n["name"].Scalar() : std::string("?");
  if (const auto key = FirstUnknownKey(n, kNodeKeys))
    throw std::runtime_error("node " + label + ": unknown key '" + *key + "' (known: " + KeyList(kNodeKeys) + ")");
  if (!n["name"] || !n["exec"]) throw std::runtime_error("every node needs 'name' and 'exec'");
  NodeSpec s;
  try {
    s.name = n["name"].as<std::string>();
    s.exec = n["exec"].as<std::string>();
    if (n["host"]) s.host = n["host"].as<std::string>();
    if (n["args"]) s.args = n["args"].as<std::vector<std::string>>();
  } catch (const YAML::Exception&) {
    throw std::runtime_error("node " + label + ": name, exec and host must be text and args a list of text");
  }
  if (!PlainName(s.name))
    throw std::runtime_error("node name '" + s.name +
                             "' must be 1-64 letters, digits, '_' or '-' (it names the node's log file)");
  if (!PlainHost(s.host))
    throw std::runtime_error("node " + s.name + ": host '" + s.host +
                             "' must be a host name or address ([user@]host: letters, digits, '.', '-', '_', ':', "
                             "'@', '[', ']', '%'; not starting with '-')");
  bool known = false;
  for (const char* e : kNodeExecs) known |= s.exec == e;
  if (!known)
    throw std::runtime_error(
        "node " + s.name + ": exec '" + s.exec +
        "' is not a hullpipe node (render_node, recon_node, sim_node, capture_node, hullpipe_bridge, "
        "hullpipe_ros2)");
  if (n["start_delay"]) {
    s.start_delay = n["start_delay"].as<double>(-1.0);  // not a number: refused here, naming the key
    if (!(s.start_delay >= 0 && s.start_delay <= 60))
      throw std::runtime_error("node " + s.name + ": start_delay must be seconds in [0, 60]");
  }
  if (n["nice"]) {
    s.nice = n["nice"].as<int>(-1);  // not an integer: refused here, naming the key
    if (s.nice < 0 || s.nice > 19) throw std::runtime_error("node " + s.name + ": nice must be an integer in [0, 19]");
  }
  return s;
}

}  // namespace

LaunchDescription ParseLaunchDescription(const std::string& yaml_text) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("not YAML: " + std::string(e.what()));
  }
  // Every key named, a misspelt one refused (it was ignored: "arg:" ran a node
  // without its arguments).
  if (!root.IsMap()) throw std::runtime_error("the file must be a map with a 'nodes' list");
  if (const auto key = FirstUnknownKey(root, {"nodes"}))
    throw std::runtime_error("unknown key '" + *key + "' (known: nodes)");
  if (!root["nodes"].IsSequence()) throw std::runtime_error("'nodes' must be a list");
  LaunchDescription d;
  std::set<std::string> names;
  for (const auto& n : root["nodes"]) {
    d.nodes.push_back(ParseNode(n));
    if (!names.insert(d.nodes.back().name).second)
      throw std::runtime_error("two nodes are named '" + d.nodes.back().name + "' (a name is its log file)");
  }
  if (d.nodes.empty() || d.nodes.front().exec != "render_node")
    throw std::runtime_error("the first node must be render_node (the parent)");
  return d;
}

LaunchDescription LoadLaunchDescription(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot read the launch description");
  std::stringstream text;
  text << in.rdbuf();
  try {
    return ParseLaunchDescription(text.str());
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
}

std::vector<std::string> ExpandArguments(const LaunchDescription& description, size_t index,
                                         const LaunchContext& context) {
  const NodeSpec& spec = description.nodes.at(index);
  std::vector<std::string> args;
  for (const auto& a : spec.args) {
    if (a == "${world}") {  // the rig's world for render and sim (none with --synthetic)
      if (!context.synthetic) args.insert(args.end(), {"--rig", context.rig});
    } else if (a == "${pace}") {  // capture's --fps where the launcher was given one
      if (!context.capture_fps.empty()) args.insert(args.end(), {"--fps", context.capture_fps});
    } else if (a == "${source}") {
      if (context.synthetic)
        args.push_back("--synthetic");
      else
        args.insert(args.end(), {"--rig", context.rig});
    } else {
      args.push_back(Substitute(a, context.vars));
    }
  }
  if (index == 0) args.insert(args.end(), context.parent_args.begin(), context.parent_args.end());
  args.insert(args.end(), {"--domain", std::to_string(context.domain), "--run-id", context.run_id});
  return args;
}

std::string QuoteForShell(const std::string& word) {
  std::string q = "'";
  for (char c : word) {
    if (c == '\'') q += "'\\''";  // close, an escaped quote, reopen
    else q += c;
  }
  return q + "'";
}

std::vector<std::string> NodeCommand(const NodeSpec& spec, const std::string& exe,
                                     const std::vector<std::string>& args, const std::string& dds_config) {
  std::vector<std::string> command;
  if (spec.nice > 0) command.insert(command.end(), {"nice", "-n", std::to_string(spec.nice)});
  command.push_back(exe);
  command.insert(command.end(), args.begin(), args.end());
  if (spec.host == "localhost" || spec.host.empty()) return command;
  // ssh joins the words after the destination with spaces and the remote
  // user's shell parses the line: each word goes quoted, so it arrives as one
  // word, unexpanded. `--` ends ssh's options before the destination.
  if (!PlainHost(spec.host)) throw std::invalid_argument("host '" + spec.host + "' is not a host name or address");
  std::string line = "env " + QuoteForShell("CYCLONEDDS_URI=file://" + dds_config);
  for (const auto& w : command) line += " " + QuoteForShell(w);
  return {"ssh", "--", spec.host, line};
}

}  // namespace hullpipe::launch
