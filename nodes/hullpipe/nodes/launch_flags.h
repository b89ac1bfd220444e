// hullpipe_launch's command line in one place: its own flags, and render_node's
// view group and recon_node's sweep group registered from render_flags.h and
// recon_flags.h (the same validators as the nodes), then resolved (render's
// view checked against the rig, the scene and the head-pose log before any
// process starts) and turned into the launch description's context
// (launch/hullpipe/launch/description.h). Unit-tested without spawning.
#pragma once

#include <cstdint>
#include <string>

#include <CLI/CLI.hpp>

#include "hullpipe/launch/description.h"
#include "hullpipe/nodes/recon_flags.h"
#include "hullpipe/nodes/render_flags.h"

namespace hullpipe::nodes {

struct LaunchFlags {
  RenderFlags render;  ///< The view group (RenderFlags::RegisterView); 320x240 unless given.
  ReconFlags recon;    ///< The sweep group (ReconFlags::RegisterSweep); 50 planes unless given.
  std::string rig;     ///< --rig DIR|FILE
  bool synthetic = false;
  int frames = 0;      ///< --frames (0: the whole input)
  double fps = 0;      ///< --fps: capture's pace (0: the source's rate)
  std::string out = "out", description, scene, bin_dir, dds_config;
  int domain = -1;     ///< --domain (-1: a lease)
  std::string run_id_text;
  uint64_t run_id = 0;  ///< Resolve: --run-id, else a new random one
  double grace = 5.0;   ///< --grace: seconds between SIGINT and SIGKILL
  double start_in = 0;  ///< --start-in: one capture timeline this many s after launch (0: none)

  LaunchFlags();
  /// Registers the launcher's flags on `app`; they write into this struct,
  /// which must outlive the parse.
  void Register(CLI::App& app);
  /// After the parse: exactly one of --rig and --synthetic; --description and
  /// --scene default to launch/local.yaml and scenes/ball.yaml under
  /// `source_dir`; the run id; render's view resolved as render_node resolves
  /// it (RenderFlags::Resolve: the rig's world, the scene's light, the
  /// head-pose log) and recon's sweep group (ReconFlags::Resolve). Throws
  /// std::invalid_argument naming the flag, or the loaders' errors naming the
  /// file.
  void Resolve(const std::string& source_dir);
  /// Every node's share of the flags (after Resolve): ${out} = out_dir,
  /// ${frames}, ${backend}, ${width}, ${height}, ${scene} (absolute), ${planes},
  /// ${start_time} (now_ns + --start-in, 0 without), the rig (absolute) or the
  /// synthetic source, capture's --fps, the run id and render_node's view flags
  /// as given (RenderFlags::GivenViewArguments).
  /// The domain is left to the caller (a lease).
  launch::LaunchContext Context(const std::string& out_dir, int64_t now_ns) const;
};

}  // namespace hullpipe::nodes
