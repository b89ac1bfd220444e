// Where hullpipe's log lines go: stderr, always. A node's or a tool's
// machine-readable output (--json, echo, a table asked for) then stands alone
// on stdout, so `tool --json | jq` works (docs/reliability.md, "Output").
#pragma once

#include <string>

namespace hullpipe {

/// Makes spdlog's default logger (every spdlog::info/warn/error) write to
/// stderr with the pattern "[time] [name] level message". Call first thing in
/// main, before anything logs. Never throws.
void LogToStderr(const std::string& name);

/// Keeps the process's command line (argv joined by spaces) for CommandLine().
/// Call once in main.
void SetCommandLine(int argc, char** argv);

/// The command line SetCommandLine kept ("" before): machine-readable output
/// carries it as "command", so a JSON file says how it was made.
const std::string& CommandLine();

}  // namespace hullpipe
