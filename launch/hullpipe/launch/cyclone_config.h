// The one writer of Cyclone DDS XML configs, for the launcher, the tests, the
// lab test and node_bench (README, "Deploying on several machines").
#pragma once

#include <string>
#include <vector>

namespace hullpipe::launch {

struct CycloneConfigOptions {
  std::string interface = "lo";                 ///< Network interface name.
  std::vector<std::string> peers{"127.0.0.1"};  ///< Unicast discovery peers (lo has no multicast).
  /// Participant announcements every second (Cyclone's default is 30 s): a lost
  /// one on a lossy link delays discovery by a second, not half a minute.
  bool fast_announcements = true;
  /// Quick repair of lost fragments of large reliable samples (maps, images,
  /// tiles): heartbeats every 10 ms, NACKs after 2 ms. With Cyclone's defaults a
  /// 5% loss cut the pipeline from 12 to 7 fps (docs/benchmarks.md).
  bool fast_repair = true;
  /// > 0: every participant drops this many of each 1000 outgoing data packets
  /// (Cyclone's Internal/Test/XmitLossiness), for packet-loss tests.
  int loss_per_mille = 0;
  std::string comment;  ///< An XML comment at the top (who wrote it and why).
};

/// The config's XML text.
std::string CycloneConfigXml(const CycloneConfigOptions& options);

/// Writes the config to `path`; returns path. Throws std::runtime_error naming
/// the path if it cannot be written.
std::string WriteCycloneConfig(const std::string& path, const CycloneConfigOptions& options);

}  // namespace hullpipe::launch
