// A launch description (launch/local.yaml and its siblings): which hullpipe nodes
// to start, where, in what order and with what arguments, and how each node's
// command line is made from it and the launcher's flags. DDS-free and
// process-free, so the launcher's rules are unit-tested without spawning
// anything (launch/main.cc only spawns and supervises).
#pragma once

#include <map>
#include <string>
#include <vector>

namespace hullpipe::launch {

/// One node of a description.
struct NodeSpec {
  /// Plain (letters, digits, '_', '-', at most 64) and unique in the file: it
  /// names the node's log, logs/<name>.log under --out.
  std::string name;
  /// capture_node, recon_node, sim_node or render_node.
  std::string exec;
  /// "localhost" runs the node here; any other host through ssh: a host name
  /// or address ([user@]host), never starting with '-' (an ssh option).
  std::string host = "localhost";
  std::vector<std::string> args;  ///< With ${...} placeholders (ExpandArguments).
  double start_delay = 0;         ///< Seconds after the previous node started, [0, 60].
  /// Scheduling niceness added to the node (`nice -n`), 0..19: a node that may
  /// take what the others leave (recon on a machine the five nodes share).
  int nice = 0;
};

/// The nodes in start order. The first is the parent (render_node): the launcher
/// runs until it ends, and it alone takes the viewpoint flags.
struct LaunchDescription {
  std::vector<NodeSpec> nodes;
};

/// Reads a description from YAML text: a map with one key, `nodes`, a list of
/// maps with keys name, exec (required), host, args, start_delay, nice. Throws
/// std::runtime_error with one line naming the node and key for an unknown or
/// misspelt key, a missing name or exec, an exec that is not a hullpipe node, a
/// name that is not plain or not unique, a start_delay or nice out of range, a
/// first node that is not render_node, or text that is not YAML.
LaunchDescription ParseLaunchDescription(const std::string& yaml_text);

/// ParseLaunchDescription of a file; errors are prefixed with the file's path.
LaunchDescription LoadLaunchDescription(const std::string& path);

/// What the launcher's flags give every node's command line.
struct LaunchContext {
  /// ${name} placeholders: out, frames, backend, width, height, scene, planes,
  /// start_time. Replaced wherever they occur in an argument.
  std::map<std::string, std::string> vars;
  std::string rig;         ///< Absolute rig path; empty with synthetic.
  bool synthetic = false;  ///< capture_node's synthetic scene instead of a rig.
  /// Flags appended to the parent's arguments (the viewpoint: --up, --floor,
  /// --orbit-*, --view file --head-poses).
  std::vector<std::string> parent_args;
  int domain = 0;
  std::string run_id;  ///< Hex, as --run-id takes it.
  /// hullpipe_launch --fps as text; empty: not given (${pace} gives nothing).
  std::string capture_fps;
};

/// The arguments of node `index` of `description`: each ${name} replaced; an
/// argument that is exactly ${source} becomes "--rig <rig>" (or "--synthetic"),
/// exactly ${world} becomes "--rig <rig>" (nothing with synthetic), exactly
/// ${pace} becomes "--fps <capture_fps>" (nothing where that is empty); the parent
/// gets context.parent_args; every node --domain and --run-id.
std::vector<std::string> ExpandArguments(const LaunchDescription& description, size_t index,
                                         const LaunchContext& context);

/// The whole command: `nice -n N` where nice > 0 (nice execs the node: its
/// pid, signals and exit status are the node's), then `exe` and `args`; for a
/// remote host, `ssh -- <host>` and one line for the remote shell, `env
/// CYCLONEDDS_URI=file://<dds_config>` and those words, each single-quoted
/// (QuoteForShell), so the node gets them as they are, unexpanded. Throws
/// std::invalid_argument for a host that is no host name or address (the
/// description's parser refuses those first).
std::vector<std::string> NodeCommand(const NodeSpec& spec, const std::string& exe,
                                     const std::vector<std::string>& args, const std::string& dds_config);

/// `word` as one word for a POSIX shell: in single quotes, a quote inside it
/// as '\''.
std::string QuoteForShell(const std::string& word);

}  // namespace hullpipe::launch
