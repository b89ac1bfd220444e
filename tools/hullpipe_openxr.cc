// hullpipe_openxr: a headset's eyes from an OpenXR runtime (docs/hmd.md, "An
// OpenXR client"): each frame's two views (xrLocateViews at the predicted
// display time) registered into the rig's world and published as EyeViews
// for render_node --view eyes-topic. Links the Khronos loader only; the
// runtime is whichever is active (XR_RUNTIME_JSON or the system's).
//   hullpipe_openxr --domain 7 [--space stage|local]
//                   [--world-from-space x,y,z,qx,qy,qz,qw] [--tracker-id 20] [--frames N]
// Ends when the runtime ends the session (exit 0), after --frames views, or
// within a second of SIGINT (the session ended first). Exits 1 with one line
// naming the OpenXR call when there is no runtime, no headset or no headless
// session.
#include <chrono>
#include <thread>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/openxr/xr_eyes.h"
#include "hullpipe/pipeline/clock.h"
#include "hullpipe/pipeline/node_counters.h"

using namespace hullpipe;
using namespace hullpipe::dds;

int main(int argc, char** argv) {
  CLI::App app{"hullpipe_openxr: a headset's eyes from an OpenXR runtime, as EyeViews for render_node"};
  CommonOptions common;
  OpenCommandLine(argc, argv, "hullpipe_openxr", app, common, /*with_run_id=*/false);
  openxr::XrClientOptions o;
  std::string world_from_space;
  uint64_t frames = 0;
  app.add_option("--space", o.space, "OpenXR reference space of the views: stage or local")->capture_default_str();
  app.add_option("--world-from-space", world_from_space,
                 "The lab's registration of that space to the rig's world: x,y,z,qx,qy,qz,qw (metres; default: "
                 "the identity)");
  app.add_option("--tracker-id", o.tracker_id, "EyeViews.tracker_id of the views sent")->capture_default_str();
  app.add_option("--frames", frames, "Stop after this many views sent (0: when the runtime ends the session)")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    if (!world_from_space.empty()) o.world_from_space = openxr::RigidFromPoseText(world_from_space, "--world-from-space");
    o.Check();
    auto participant = StartNode("openxr", common);
    Writer<hullpipe_msg_EyeViews> writer(*participant);
    SystemClock clock;
    NodeCounters counters(clock);
    NodeReporter reporter(*participant, "openxr", counters);
    openxr::XrEyeSession session(o);
    spdlog::info("OpenXR runtime {}; locating both eyes in its {} space", session.runtime(), o.space);
    uint64_t sent = 0;
    std::string last_skip;
    while (!StopRequested() && !session.exiting() && (frames == 0 || sent < frames)) {
      if (auto views = session.Step()) {
        writer.Write(EyeViewsToMsg(*views));
        ++sent;
        counters.FrameOut(views->stamp_ns);
      } else if (!session.running()) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));  // not begun yet, or stopping
      } else if (session.last_skip() != last_skip) {
        last_skip = session.last_skip();
        spdlog::warn("views not sent: {}", last_skip);  // once per reason in a row
      }
      const auto& c = session.counts();
      counters.SetRejected(c.untracked + c.refused);
    }
    // The session ended before the process: the runtime gets its frames back.
    session.RequestExit();
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(500);
    while (!session.exiting() && std::chrono::steady_clock::now() < until) {
      session.Step();
      if (!session.running()) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    const auto& c = session.counts();
    spdlog::info("sent {} eye views of {} frames; {} untracked, {} refused", sent, c.frames, c.untracked, c.refused);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
