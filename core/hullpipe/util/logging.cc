#include "hullpipe/util/logging.h"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

namespace hullpipe {

void LogToStderr(const std::string& name) {
  try {
    auto logger = std::make_shared<spdlog::logger>(name, std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
    spdlog::set_default_logger(std::move(logger));
    spdlog::set_pattern("[%H:%M:%S.%e] [" + name + "] %^%l%$ %v");
  } catch (const std::exception&) {
    // A logger that cannot be set leaves spdlog's own: output still works.
  }
}

namespace {
std::string& Command() {
  static std::string command;
  return command;
}
}  // namespace

void SetCommandLine(int argc, char** argv) {
  std::string s;
  for (int i = 0; i < argc; ++i) s += (i ? " " : "") + std::string(argv[i] ? argv[i] : "");
  Command() = s;
}

const std::string& CommandLine() { return Command(); }

}  // namespace hullpipe
