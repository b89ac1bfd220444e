// hullpipe_cmd: sends a command to running nodes and tools.
//   hullpipe_cmd --domain 7 set-spacing 0.20     sim_node (paper §5.2: PMT-to-payload-A
//                                                spacing without a restart)
//   hullpipe_cmd --domain 7 snapshot             hullpipe_record --snapshot-seconds:
//                                                write the last N seconds now
//   hullpipe_cmd --domain 7 pause | resume | step [N] | seek SECONDS | rate X
//                                                hullpipe_replay (docs/recording.md)
// Waits (up to --timeout s) until a reader matches, so the command is not lost,
// and exits 0 once every reader acknowledged it; 1 if no reader came or none
// acknowledged within 2 s.
#include <cmath>
#include <chrono>
#include <thread>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/util/logging.h"

using namespace hullpipe::dds;

namespace {

// Waits for a reader, writes `msg`, waits for its acknowledgement; 0 or 1.
template <typename T>
int Send(const Participant& participant, const T& msg, double timeout, const std::string& what,
         const std::string& listener) {
  Writer<T> writer(participant);
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout);
  while (writer.MatchedReaders() == 0) {
    if (StopRequested()) return 1;
    if (std::chrono::steady_clock::now() > until) {
      spdlog::error("{}: no {} listened within {} s", what, listener, timeout);
      return 1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  writer.Write(msg);
  // Reliable delivery: give the reader time to acknowledge before leaving.
  const dds_return_t rc = dds_wait_for_acks(writer.handle(), DDS_SECS(2));
  if (rc == DDS_RETCODE_TIMEOUT) {
    spdlog::error("{}: not acknowledged by {} within 2 s", what, listener);
    return 1;
  }
  Check(rc, "dds_wait_for_acks");
  spdlog::info("sent {}", what);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hullpipe_cmd: change the running virtual scene, trigger a recorder's snapshot, steer a replay"};
  CommonOptions common;
  OpenCommandLine(argc, argv, "hullpipe_cmd", app, common);
  double timeout = 10;
  app.add_option("--timeout", timeout, "Seconds to wait for a listener")->capture_default_str();
  double spacing = 0, seek = 0, rate = 1;
  int steps = 1;
  auto* set_spacing = app.add_subcommand("set-spacing", "sim_node: PMT-to-payload-A spacing, metres (e.g. 0.20)");
  set_spacing->add_option("metres", spacing, "Spacing in metres, [0, 10]")->required();
  auto* snapshot = app.add_subcommand("snapshot", "hullpipe_record --snapshot-seconds: write the last seconds now");
  auto* pause = app.add_subcommand("pause", "hullpipe_replay: pause");
  auto* resume = app.add_subcommand("resume", "hullpipe_replay: resume");
  auto* step = app.add_subcommand("step", "hullpipe_replay, paused: release N samples");
  step->add_option("samples", steps, "Samples, [1, 1000000]")->capture_default_str();
  auto* seek_cmd = app.add_subcommand("seek", "hullpipe_replay: jump to SECONDS after the recording's start");
  seek_cmd->add_option("seconds", seek, "Seconds, [0, 1e6]")->required();
  auto* rate_cmd = app.add_subcommand("rate", "hullpipe_replay: play at rate X (0: as fast as readers take it)");
  rate_cmd->add_option("x", rate, "0 or [0.001, 1000]")->required();
  for (auto* sub : {set_spacing, snapshot, pause, resume, step, seek_cmd, rate_cmd})
    sub->fallthrough();  // --domain etc. may follow the subcommand
  app.require_subcommand(1);
  CLI11_PARSE(app, argc, argv);
  try {
    // (Checked here, not by CLI11's Range: NaN passes it, as every comparison with NaN is false.)
    if (!std::isfinite(spacing) || spacing < 0 || spacing > 10)
      throw std::invalid_argument("set-spacing: metres must be a finite number in [0, 10]");
    if (!(seek >= 0 && seek <= 1e6)) throw std::invalid_argument("seek: seconds must be in [0, 1e6]");
    if (!(rate == 0 || (rate >= 1e-3 && rate <= 1e3)))
      throw std::invalid_argument("rate: x must be 0 or in [0.001, 1000]");
    if (steps < 1 || steps > 1'000'000) throw std::invalid_argument("step: samples must be in [1, 1000000]");
    if (!(timeout > 0 && timeout <= 3600)) throw std::invalid_argument("--timeout must be in (0, 3600] s");
    auto participant = StartNode("cmd", common);
    if (*set_spacing) {
      hullpipe_msg_SceneCommand c{};
      c.command_seq = 1;
      c.stamp_ns = hullpipe::NowNs();
      c.command = hullpipe_msg_SCENE_COMMAND_SET_SPACING;
      c.value = spacing;
      return Send(*participant, c, timeout, fmt::format("set-spacing {:.3f} m", spacing), "sim_node");
    }
    hullpipe_msg_RecordCommand c{};
    c.command_seq = 1;
    c.stamp_ns = hullpipe::NowNs();
    std::string what, listener = "hullpipe_replay";
    if (*snapshot) c.command = hullpipe_msg_RECORD_COMMAND_SNAPSHOT, what = "snapshot", listener = "hullpipe_record";
    if (*pause) c.command = hullpipe_msg_RECORD_COMMAND_PAUSE, what = "pause";
    if (*resume) c.command = hullpipe_msg_RECORD_COMMAND_RESUME, what = "resume";
    if (*step) c.command = hullpipe_msg_RECORD_COMMAND_STEP, c.value = steps, what = fmt::format("step {}", steps);
    if (*seek_cmd) c.command = hullpipe_msg_RECORD_COMMAND_SEEK, c.value = seek, what = fmt::format("seek {} s", seek);
    if (*rate_cmd) c.command = hullpipe_msg_RECORD_COMMAND_RATE, c.value = rate, what = fmt::format("rate {}", rate);
    return Send(*participant, c, timeout, what, listener);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
