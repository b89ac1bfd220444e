#include "hullpipe/nodes/recon_flags.h"

#include <algorithm>

namespace hullpipe::nodes {

void ReconFlags::RegisterSweep(CLI::App& app) {
  app.add_option("--backend", backend.name, "Sweep backend: cpu|gl|auto")
      ->check(CLI::IsMember({"cpu", "gl", "auto"}))
      ->capture_default_str();
  app.add_option("--planes", options.sweep.num_planes, "Sweep planes")->capture_default_str();
}

void ReconFlags::Register(CLI::App& app) {
  ReconOptions& o = options;
  app.add_option("--tile", tile, "This node's tile i/N of the view (horizontal bands)")->capture_default_str();
  RegisterSweep(app);
  app.add_option("--gl-method", backend.gl_method,
                 "GL sweep: march (compute-shader ray march, refinement on the GPU) or stencil (the paper's "
                 "stencil counting)")
      ->check(CLI::IsMember({"march", "stencil"}))
      ->capture_default_str();
  app.add_option("--gl-device", backend.gl_device, "EGL device index for GL (-1: the first hardware device)")
      ->check(CLI::Range(-1, 64))
      ->capture_default_str();
  app.add_option("--threads", o.threads,
                 "CPU threads of the sweep, visibility maps and hull box (0: this host's cores shared among its "
                 "recon nodes)")
      ->capture_default_str();
  app.add_option("--refine", o.refine, "Depth refinement bisections after the sweep (0: the paper's plane depth)")
      ->check(CLI::Range(0, 30))
      ->capture_default_str();
  app.add_option("--visibility-width", o.visibility_width,
                 "Width of each camera's hull depth map for the texture visibility test (0: no test)")
      ->check(CLI::Range(0, 4096))
      ->capture_default_str();
  app.add_option("--out-of-view", out_of_view,
                 "A camera that cannot see a point: unknown (does not vote) or outside (vetoes, as the paper)")
      ->check(CLI::IsMember({"unknown", "outside"}))
      ->capture_default_str();
  app.add_option("--failover", o.failover,
                 "A peer recon node silent (no NodeStats) this many s: the lowest live tile renders its tile too")
      ->capture_default_str();
  app.add_option("--pose-timeout", o.pose_timeout, "Drop a pose whose frameset has not arrived after this many s")
      ->capture_default_str();
}

void ReconFlags::Resolve() {
  options.ParseTile(tile);
  options.out_of_view = out_of_view == "outside" ? OutOfView::kOutside : OutOfView::kUnknown;
  options.Check();
  backend.threads = std::max(1, options.threads);  // 0: decided per frameset (ReconController::ThreadsNow)
  backend.refine = options.refine;
  backend.Check();
}

}  // namespace hullpipe::nodes
