// libFuzzer: what a Foxglove WebSocket client sends hullpipe_bridge
// (hullpipe/foxglove/bridge_state.h, BridgeState::OnText), as its text messages reach the
// protocol state: the input is one or more messages separated by NUL bytes,
// from one client, with a sample routed after each. Beyond "no crash": every
// reply is bounded (a status names at most kMaxEcho bytes of the input), a
// client never holds two subscriptions to one channel, so a routed sample goes
// out at most once per channel, and nothing else is sent unasked. Run with a
// memory limit (scripts/fuzz.sh: -rss_limit_mb=2048).
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "hullpipe/foxglove/bridge_state.h"

using hullpipe::bridge::BridgeState;
using hullpipe::bridge::Channel;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<Channel> channels;
  for (uint32_t id = 1; id <= 3; ++id)
    channels.push_back({id, "hullpipe/topic" + std::to_string(id), "cdr", "T", "schema", "omgidl"});
  BridgeState state(channels, 2, "fuzz");
  state.Open(1, "session");
  state.Latch(2, "cam1", 5, {1, 2, 3});
  const std::string all(reinterpret_cast<const char*>(data), size);
  size_t at = 0;
  while (at <= all.size()) {
    size_t end = all.find('\0', at);
    if (end == std::string::npos) end = all.size();
    const std::string text = all.substr(at, end - at);
    for (const auto& o : state.OnText(1, text)) {
      if (o.client != 1) std::abort();  // replies go to the sender alone
      if (!o.binary && o.payload.size() > 512) std::abort();  // a status, bounded
      if (o.binary && o.payload.size() != 13 + 3) std::abort();  // the latched sample, nothing else
    }
    const std::vector<uint8_t> sample(1024, 7);
    for (uint32_t ch = 1; ch <= 4; ++ch)
      if (state.Route(ch, 9, sample).size() > 1) std::abort();  // one subscription a channel
    at = end + 1;
  }
  return 0;
}
