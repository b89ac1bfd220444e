#include "hullpipe/nodes/launch_flags.h"

#include <filesystem>
#include <stdexcept>

#include "hullpipe/util/cli_range.h"
#include "hullpipe/util/run_id.h"

namespace hullpipe::nodes {

namespace fs = std::filesystem;

LaunchFlags::LaunchFlags() {
  // The launcher's defaults: a small view and sweep that the five processes
  // keep at the rig's rate on a laptop.
  render.options.width = 320;
  render.options.height = 240;
  recon.options.sweep.num_planes = 50;
}

void LaunchFlags::Register(CLI::App& app) {
  app.add_option("--rig", rig, "Rig directory or YAML rig file");
  app.add_flag("--synthetic", synthetic, "Use capture_node's built-in synthetic scene");
  app.add_option("--frames", frames, "Frames to process (0: the whole input)")->check(CLI::Range(0, 100000000));
  app.add_option("--fps", fps,
                 "Pace every capture node at this rate, frames per second (0: the source's rate); "
                 "a rig too large for the machine composites every frame at a rate it keeps")
      ->check(FiniteRange(0.0, 1000.0));
  app.add_option("--out", out, "Output directory")->capture_default_str();
  app.add_option("--description", description, "Launch description YAML (default: launch/local.yaml)");
  app.add_option("--scene", scene, "Scene file for sim_node (default: scenes/ball.yaml)");
  render.RegisterView(app);
  recon.RegisterSweep(app);
  app.add_option("--domain", domain, "DDS domain id (default: unique per run, from the pid)")
      ->check(DomainIdRange());
  app.add_option("--run-id", run_id_text,
                 "This run's id, 1-16 hex digits, given to every node (default: a random one); render_node and "
                 "recon_node ignore samples of another run on the domain")
      ->check(RunIdValidator());
  app.add_option("--dds-config", dds_config, "Cyclone XML config (default: loopback config written to --out)");
  app.add_option("--bin-dir", bin_dir, "Directory of the node executables (default: beside this one)");
  app.add_option("--grace", grace, "Seconds between SIGINT and SIGKILL at shutdown")
      ->check(FiniteRange(0.1, 600.0))
      ->capture_default_str();
  app.add_option("--start-in", start_in,
                 "Give the capture nodes one timeline starting this many seconds after launch, as ${start_time} "
                 "(0: the first capture node announces one)")
      ->check(FiniteRange(0.0, 600.0))
      ->capture_default_str();
}

void LaunchFlags::Resolve(const std::string& source_dir) {
  if (rig.empty() == !synthetic) throw std::invalid_argument("give exactly one of --rig DIR or --synthetic");
  if (description.empty()) description = source_dir + "/launch/local.yaml";
  if (scene.empty()) scene = source_dir + "/scenes/ball.yaml";
  run_id = run_id_text.empty() ? NewRunId() : *ParseRunId(run_id_text);
  // render_node's view as render_node will resolve it: the rig's world (with
  // --rig; ${world}), the scene's light, the head-pose log.
  render.rig = rig;
  render.scene = scene;
  // --view as given (a tracker's or a headset client's topic), else as the
  // files imply.
  if (!render.view_given())
    render.view = !render.eye_views.empty() ? "eyes" : render.head_poses.empty() ? "orbit" : "file";
  render.Resolve(/*have_display=*/false);
  recon.Resolve();
}

launch::LaunchContext LaunchFlags::Context(const std::string& out_dir, int64_t now_ns) const {
  launch::LaunchContext ctx;
  const int64_t start_ns = start_in > 0 ? now_ns + int64_t(start_in * 1e9) : 0;
  ctx.vars = {{"out", out_dir},
              {"frames", std::to_string(frames)},
              {"backend", recon.backend.name},
              {"width", std::to_string(render.options.width)},
              {"height", std::to_string(render.options.height)},
              {"scene", fs::absolute(scene).string()},
              {"planes", std::to_string(recon.options.sweep.num_planes)},
              {"start_time", std::to_string(start_ns)}};
  ctx.synthetic = synthetic;
  if (!synthetic) ctx.rig = fs::absolute(rig).string();
  if (fps > 0) ctx.capture_fps = CLI::detail::to_string(fps);
  ctx.parent_args = render.GivenViewArguments();
  ctx.run_id = RunIdText(run_id);
  return ctx;
}

}  // namespace hullpipe::nodes
