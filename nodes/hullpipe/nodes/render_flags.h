// render_node's command line in one place: every flag registered once into
// RenderOptions and RenderOutputOptions, then resolved (the head-pose log, the
// scene's light, the rig's world under the world flags) and checked before any
// participant starts. hullpipe_launch registers the view group (RegisterView)
// from here too and hands what was given to render_node. Unit-tested by parsing
// argument lists.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "hullpipe/nodes/render_controller.h"
#include "hullpipe/nodes/render_outputs.h"

namespace hullpipe::nodes {

struct RenderFlags {
  RenderOptions options;
  RenderOutputOptions outputs;
  std::string window = "auto";  ///< --window auto|on|off
  std::string view = "orbit";   ///< --view orbit|file|topic|eyes|eyes-topic
  std::string head_poses, eye_views, scene, rig;

  /// Registers render_node's own flags on `app`: RegisterView and the rest.
  /// They write into this struct, which must outlive the parse.
  void Register(CLI::App& app);
  /// The view group alone, the flags hullpipe_launch takes for render_node:
  /// --width, --height, --up, --floor, --orbit-radius, --orbit-height,
  /// --stereo, --ipd, --fov-left, --fov-right, --eye-views, --view,
  /// --head-poses.
  void RegisterView(CLI::App& app);
  /// Whether --view was given (after the parse).
  bool view_given() const { return view_opt_ && view_opt_->count() > 0; }
  /// After Resolve: the view group's flags that were given, but for --width and
  /// --height, as render_node's arguments: each as given (a list joined with
  /// ','), --head-poses as "--view file --head-poses <its absolute path>" and
  /// --eye-views as "--view eyes --eye-views <its absolute path>" (the node may
  /// start in another directory), --view file and --view eyes left to them.
  std::vector<std::string> GivenViewArguments() const;
  /// After the parse: --view file with --head-poses (loaded), the scene's
  /// light, the rig's world with --up, --floor and --orbit-* over it
  /// (RenderOptions::ApplyWorld), the window (have_display: for `auto`), then
  /// RenderOptions::Check, while the app that parsed still lives (the view
  /// flags given are kept for GivenViewArguments). Throws
  /// std::invalid_argument naming the flag, or the loaders' errors naming the
  /// file.
  void Resolve(bool have_display);

 private:
  std::vector<double> orbit_centre_, up_;
  double orbit_radius_ = 0, orbit_height_ = 0;
  WorldFlags world_;
  CLI::Option *up_opt_ = nullptr, *radius_opt_ = nullptr, *height_opt_ = nullptr, *view_opt_ = nullptr;
  bool stereo_ = false;
  double ipd_ = 0.064;
  std::vector<double> fov_left_, fov_right_;
  CLI::Option *ipd_opt_ = nullptr, *fov_left_opt_ = nullptr, *fov_right_opt_ = nullptr;
  std::vector<CLI::Option*> view_options_;  ///< RegisterView's, in order (they live in the app)
  std::vector<std::pair<std::string, std::string>> given_view_;  ///< Resolve: those given, name and value
};

}  // namespace hullpipe::nodes
