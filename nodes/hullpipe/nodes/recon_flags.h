// recon_node's command line in one place (as render_flags.h for render_node):
// every flag registered once into ReconOptions and the sweep backend's
// BackendOptions, then resolved and checked before any participant starts.
// hullpipe_launch registers the sweep group (RegisterSweep) from here too, so
// the launcher and the node take --backend and --planes with the same checks.
// Unit-tested by parsing argument lists.
#pragma once

#include <string>

#include <CLI/CLI.hpp>

#include "hullpipe/nodes/recon_controller.h"
#include "hullpipe/reconstruction/sweep_backend.h"

namespace hullpipe::nodes {

struct ReconFlags {
  ReconOptions options;     ///< --tile (at Resolve), --planes, --threads, --refine, --visibility-width, ...
  BackendOptions backend;   ///< --backend, --gl-method, --gl-device (threads and refine at Resolve)
  std::string tile = "0/1";           ///< --tile i/N
  std::string out_of_view = "unknown";  ///< --out-of-view unknown|outside

  /// Registers recon_node's own flags on `app` (the common DDS and frameset
  /// flags are dds/node.h's and dds/frameset_input.h's): RegisterSweep and the
  /// rest. They write into this struct, which must outlive the parse.
  void Register(CLI::App& app);
  /// The sweep group alone, the flags hullpipe_launch hands to every recon
  /// node: --backend cpu|gl|auto and --planes.
  void RegisterSweep(CLI::App& app);
  /// After the parse: --tile parsed, --out-of-view set, ReconOptions::Check and
  /// BackendOptions::Check, the backend's threads (at least 1: 0 is decided per
  /// frameset) and refinement from the options. Throws std::invalid_argument
  /// naming the flag.
  void Resolve();
};

}  // namespace hullpipe::nodes
