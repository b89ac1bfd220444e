// render_node's command line in one place: every flag registered once into
// RenderOptions and RenderOutputOptions, then resolved (the head-pose log, the
// scene's light, the rig's world under the world flags) and checked before any
// participant starts. Unit-tested by parsing argument lists.
#pragma once

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "hullpipe/nodes/render_controller.h"
#include "hullpipe/nodes/render_outputs.h"

namespace hullpipe::nodes {

struct RenderFlags {
  RenderOptions options;
  RenderOutputOptions outputs;
  std::string window = "auto";  ///< --window auto|on|off
  std::string view = "orbit";   ///< --view orbit|file|topic
  std::string head_poses, scene, rig;

  /// Registers render_node's own flags on `app`; they write into this struct,
  /// which must outlive the parse.
  void Register(CLI::App& app);
  /// After the parse: --view file with --head-poses (loaded), the scene's
  /// light, the rig's world with --up, --floor and --orbit-* over it
  /// (RenderOptions::ApplyWorld), the window (have_display: for `auto`), then
  /// RenderOptions::Check. Throws std::invalid_argument naming the flag, or the
  /// loaders' errors naming the file.
  void Resolve(bool have_display);

 private:
  std::vector<double> orbit_centre_, up_;
  double orbit_radius_ = 0, orbit_height_ = 0;
  WorldFlags world_;
  CLI::Option *up_opt_ = nullptr, *radius_opt_ = nullptr, *height_opt_ = nullptr;
};

}  // namespace hullpipe::nodes
