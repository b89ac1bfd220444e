#include "hullpipe/nodes/render_flags.h"

#include <filesystem>
#include <optional>
#include <stdexcept>

#include "hullpipe/geometry/calibration.h"
#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/util/cli_range.h"

namespace hullpipe::nodes {

void RenderFlags::RegisterView(CLI::App& app) {
  view_options_.clear();
  auto keep = [this](CLI::Option* opt) {
    view_options_.push_back(opt);
    return opt;
  };
  keep(app.add_option("--width", options.width, "Novel view width")->capture_default_str());
  keep(app.add_option("--height", options.height, "Novel view height")->capture_default_str());
  up_opt_ = keep(app.add_option("--up", up_, "World up vector (default: the rig's; Utrecht rig: 0,0,-1)")
                     ->delimiter(',')
                     ->expected(3));
  keep(app.add_option("--floor", world_.floor,
                      "Floor: metres along up (plane up . x = H), 'hull' (under the first hull) or 'none' (default: "
                      "the rig's; Utrecht: 0)"));
  radius_opt_ = keep(app.add_option("--orbit-radius", orbit_radius_, "Orbit radius, metres (default: the rig's; 3)")
                         ->check(FiniteRange(0.01, 1000.0)));
  height_opt_ = keep(app.add_option("--orbit-height", orbit_height_,
                                    "Eye height above the centre, metres (default: the rig's; 0.7)")
                         ->check(FiniteRange(-1000.0, 1000.0)));
  keep(app.add_flag("--stereo", stereo_,
                                  "A head-mounted display's two eyes: each head pose gives a left and a right eye "
                                  "(--width x --height each, side by side in the video; docs/hmd.md)"));
  ipd_opt_ = keep(app.add_option("--ipd", ipd_, "With --stereo: interpupillary distance, metres [0.04, 0.09] (0.064)")
                      ->check(FiniteRange(0.0, 1.0)));
  fov_left_opt_ = keep(app.add_option("--fov-left", fov_left_,
                                      "With --stereo: the left eye's field of view as OpenXR's XrFovf, "
                                      "left,right,up,down in radians (-0.9425,0.6981,0.8378,-0.8378)")
                           ->delimiter(',')
                           ->expected(4));
  fov_right_opt_ = keep(app.add_option("--fov-right", fov_right_,
                                       "With --stereo: the right eye's (default: the left's mirrored)")
                            ->delimiter(',')
                            ->expected(4));
  keep(app.add_option("--eye-views", eye_views,
                      "Per-eye poses and fields of view as an HMD runtime reports them (xrLocateViews), CSV "
                      "t,eye,px,py,pz,qx,qy,qz,qw,left,right,up,down (docs/hmd.md); stereo, --width x --height each"));
  view_opt_ = keep(
      app.add_option("--view", view,
                     "Viewpoint: orbit (scripted), file (--head-poses CSV), topic (HeadPose from a tracker; "
                     "the orbit until the first arrives), eyes (--eye-views CSV: each eye as an HMD runtime reports "
                     "it), eyes-topic (EyeViews from an HMD runtime's client, live; the orbit's eyes until the first)")
          ->check(CLI::IsMember({"orbit", "file", "topic", "eyes", "eyes-topic"}))
          ->capture_default_str());
  keep(app.add_option("--head-poses", head_poses,
                      "Tracked head poses, CSV t,x,y,z,qw,qx,qy,qz (world_from_eye, OpenCV eye frame; t in seconds "
                      "from the first frame)"));
}

std::vector<std::string> RenderFlags::GivenViewArguments() const {
  std::vector<std::string> args;
  for (const auto& [name, value] : given_view_) {
    if (name == "--width" || name == "--height") continue;  // the description's ${width}, ${height}
    if (name == "--stereo") {  // a flag: no value
      args.push_back(name);
      continue;
    }
    // --view file and --view eyes come with their files' flags (below).
    if (name == "--view" && (value == "file" || value == "eyes")) continue;
    if (name == "--eye-views") {
      args.insert(args.end(), {"--view", "eyes", "--eye-views", std::filesystem::absolute(value).string()});
      continue;
    }
    if (name == "--head-poses") {
      args.insert(args.end(), {"--view", "file", "--head-poses", std::filesystem::absolute(value).string()});
      continue;
    }
    args.insert(args.end(), {name, value});
  }
  return args;
}

void RenderFlags::Register(CLI::App& app) {
  RenderOptions& o = options;
  RegisterView(app);
  app.add_option("--out", outputs.out_dir, "Output directory (video, PNGs, stats.json)")->capture_default_str();
  app.add_option("--frames", o.max_frames, "Stop after compositing the frameset with this sequence number");
  app.add_option("--hfov", o.hfov_deg, "Horizontal field of view, degrees")->capture_default_str();
  app.add_option("--tiles", o.tiles, "Recon tiles per frame (number of recon nodes)")->capture_default_str();
  app.add_option("--max-in-flight", o.max_in_flight, "Poses rendered concurrently")->capture_default_str();
  app.add_option("--png-every", outputs.png_every, "Write every K-th composited frame as PNG (0: none)")
      ->check(CLI::Range(0, 1000000));
  app.add_flag("--save-depth", outputs.save_depth,
               "With each PNG, the hull's depth (frame_N_depth.tiff, float eye z in metres) and its view (views.csv: "
               "K, world_from_eye)");
  app.add_option("--video-fps", outputs.video_fps, "Frame rate written into the video")
      ->check(FiniteRange(1.0, 1000.0))
      ->capture_default_str();
  app.add_option("--idle-timeout", o.idle_timeout, "Stop when no new frameset came for this many s")
      ->capture_default_str();
  app.add_option("--tile-timeout", o.tile_timeout,
                 "Give up on a pose's missing tiles after this many s, at first: a tile that comes later for a pose "
                 "given up raises it to twice that tile's round trip (at most 60 s)")
      ->capture_default_str();
  app.add_option("--orbit-centre", orbit_centre_, "Orbit centre x,y,z in world metres (default: hull box centre)")
      ->delimiter(',')
      ->expected(3);
  app.add_option("--orbit-period", o.orbit_period, "Seconds per turn (frame time)")->capture_default_str();
  app.add_option("--scene", scene, "Scene file: render_node uses its `light` (shadows); sim_node the rest");
  app.add_option("--rig", rig,
                 "Rig directory or YAML rig file: its world (up, floor, orbit) unless the flags say otherwise "
                 "(default: the Utrecht rig's world)");
  app.add_flag("--publish-view,!--no-publish-view", o.publish_composite,
               "Publish each composited frame as a JPEG (CompositedView: hullpipe_bridge's /foxglove/composited, "
               "recordings)")
      ->capture_default_str();
  app.add_option("--publish-max-side", o.publish_max_side,
                 "Published frames larger than this many pixels a side are scaled down")
      ->capture_default_str();
  app.add_option("--publish-jpeg-quality", o.publish_jpeg_quality, "JPEG quality of the published frames (1..100)")
      ->capture_default_str();
  app.add_option("--window", window, "Show the output in a window: auto (where a display exists), on, off")
      ->check(CLI::IsMember({"auto", "on", "off"}))
      ->capture_default_str();
}

void RenderFlags::Resolve(bool have_display) {
  RenderOptions& o = options;
  // The view group as given, while the parse's options live (the app may go
  // before this struct does).
  given_view_.clear();
  for (const CLI::Option* opt : view_options_) {
    if (opt->count() == 0) continue;
    std::string value;  // the values joined as the flag takes them (--up x,y,z)
    for (const std::string& r : opt->results()) value += (value.empty() ? "" : ",") + r;
    given_view_.emplace_back(opt->get_name(), value);
  }
  if ((view == "file") != !head_poses.empty())
    throw std::invalid_argument("--view file goes with --head-poses FILE");
  if ((view == "eyes") != !eye_views.empty())
    throw std::invalid_argument("--view eyes goes with --eye-views FILE");
  o.view = view == "file"         ? RenderOptions::View::kFile
           : view == "topic"      ? RenderOptions::View::kTopic
           : view == "eyes"       ? RenderOptions::View::kEyes
           : view == "eyes-topic" ? RenderOptions::View::kEyesTopic
                                  : RenderOptions::View::kOrbit;
  if (view == "eyes-topic") stereo_ = true;  // the runtime's two views
  if (!head_poses.empty()) o.track = LoadPoseTrack(head_poses);
  if (!eye_views.empty()) {
    o.eye_track = LoadStereoViewTrack(eye_views);
    stereo_ = true;  // the runtime's two views
  }
  if (!scene.empty()) o.light = LoadSceneConfig(scene, SceneLoadOptions{false}).light;
  if (up_opt_ && up_opt_->count()) world_.up = Eigen::Vector3d(up_[0], up_[1], up_[2]);
  if (radius_opt_ && radius_opt_->count()) world_.orbit_radius = orbit_radius_;
  if (height_opt_ && height_opt_->count()) world_.orbit_height = orbit_height_;
  const std::optional<RigWorld> rig_world = rig.empty() ? std::nullopt : std::optional<RigWorld>(LoadRig(rig).world);
  o.ApplyWorld(rig_world ? &*rig_world : nullptr, world_);
  const bool stereo_settings = ipd_opt_->count() || fov_left_opt_->count() || fov_right_opt_->count();
  if (stereo_settings && !stereo_) throw std::invalid_argument("--ipd, --fov-left and --fov-right go with --stereo");
  if (stereo_settings && (view == "eyes" || view == "eyes-topic"))
    throw std::invalid_argument("--ipd, --fov-left and --fov-right do not go with --view " + view +
                                ": the HMD runtime gives each eye's pose and field of view");
  if (stereo_) {
    StereoOptions so;
    if (ipd_opt_->count()) so.ipd_m = ipd_;
    auto fov = [](const std::vector<double>& v) { return EyeFov{v[0], v[1], v[2], v[3]}; };
    if (fov_left_opt_->count()) so.left = fov(fov_left_);
    so.right = so.left.Mirrored();
    if (fov_right_opt_->count()) so.right = fov(fov_right_);
    o.stereo = so;
  }
  if (orbit_centre_.size() == 3) o.orbit_centre = Eigen::Vector3d(orbit_centre_[0], orbit_centre_[1], orbit_centre_[2]);
  outputs.show = window == "on" || (window == "auto" && have_display);
  o.Check();
}

}  // namespace hullpipe::nodes
