// hullpipe_cmd: sends a SceneCommand to a running sim_node (paper §5.2: change
// the spacing between the PMT box and payload A without a restart).
//   hullpipe_cmd --domain 7 set-spacing 0.20
// Waits (up to --timeout s) until a sim_node's reader matches, so the command is
// not lost, and exits 0 once it is written; 1 if no reader came.
#include <cmath>
#include <chrono>
#include <thread>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/dds/topics.h"

using namespace hullpipe::dds;

int main(int argc, char** argv) {
  CLI::App app{"hullpipe_cmd: change the running virtual scene"};
  CommonOptions common;
  AddCommonOptions(app, common);
  double timeout = 10;
  app.add_option("--timeout", timeout, "Seconds to wait for a sim_node to listen")->capture_default_str();
  double spacing = 0;
  auto* set_spacing = app.add_subcommand("set-spacing", "PMT-to-payload-A spacing, metres (e.g. 0.20)");
  set_spacing->add_option("metres", spacing, "Spacing in metres, [0, 10]")->required();
  set_spacing->fallthrough();  // --domain etc. may follow the subcommand
  app.require_subcommand(1);
  CLI11_PARSE(app, argc, argv);
  try {
    // (Checked here, not by CLI11's Range: NaN passes it, as every comparison with NaN is false.)
    if (!std::isfinite(spacing) || spacing < 0 || spacing > 10)
      throw std::invalid_argument("set-spacing: metres must be a finite number in [0, 10]");
    if (!(timeout > 0 && timeout <= 3600)) throw std::invalid_argument("--timeout must be in (0, 3600] s");
    auto participant = StartNode("cmd", common);
    Writer<hullpipe_msg_SceneCommand> writer(*participant);
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout);
    while (writer.MatchedReaders() == 0) {
      if (std::chrono::steady_clock::now() > until) {
        spdlog::error("no sim_node listened within {} s", timeout);
        return 1;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    hullpipe_msg_SceneCommand c{};
    c.command_seq = 1;
    c.stamp_ns = hullpipe::NowNs();
    c.command = hullpipe_msg_SCENE_COMMAND_SET_SPACING;
    c.value = spacing;
    writer.Write(c);
    // Reliable delivery: give the reader time to acknowledge before leaving.
    const dds_return_t rc = dds_wait_for_acks(writer.handle(), DDS_SECS(2));
    if (rc == DDS_RETCODE_TIMEOUT) {
      spdlog::error("set-spacing {:.3f} m: not acknowledged by sim_node within 2 s", spacing);
      return 1;
    }
    Check(rc, "dds_wait_for_acks");
    spdlog::info("sent set-spacing {:.3f} m", spacing);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
