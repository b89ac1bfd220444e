// hullpipe_bridge's state, apart from DDS and the WebSocket library (tested alone
// in tests/bridge_test.cc): the Foxglove WebSocket protocol's channels, clients
// and subscriptions (https://github.com/foxglove/ws-protocol, spec v1:
// serverInfo, advertise, subscribe, unsubscribe, status, binary message data),
// the bound on clients, and which channels anyone wants (the bridge reads a DDS
// topic only while someone is subscribed: an idle bridge costs the pipeline
// nothing).
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <vector>

namespace hullpipe::bridge {

/// One advertised channel: a DDS topic, its samples as recorded (cdr, the
/// type's omgidl schema).
struct Channel {
  uint32_t id = 0;
  std::string topic, encoding, schema_name, schema, schema_encoding;
};

/// A message to send to one client.
struct Outgoing {
  uint64_t client = 0;
  bool binary = false;
  std::string payload;
};

/// Thread-safe: the WebSocket thread calls Open/Close/OnText, the DDS thread
/// Route and Wanted.
class BridgeState {
 public:
  /// max_clients >= 1.
  BridgeState(std::vector<Channel> channels, int max_clients, std::string name);

  /// A client asks to connect with these subprotocols: the one the bridge
  /// speaks ("foxglove.sdk.v1" preferred, then "foxglove.websocket.v1"), or ""
  /// to refuse (none spoken, or max_clients connected; *why says which).
  std::string Accept(const std::vector<std::string>& subprotocols, std::string* why) const;
  /// A client connected: the serverInfo and advertise messages to send it.
  std::vector<Outgoing> Open(uint64_t client, const std::string& session_id);
  void Close(uint64_t client);
  /// A text message from a client: subscribe / unsubscribe (others, and client
  /// publishing, answered with a status error); what to send back.
  std::vector<Outgoing> OnText(uint64_t client, const std::string& text);
  /// A sample of channel `channel` received at `stamp_ns`: one binary message
  /// (opcode 1, subscription id, timestamp, payload) per subscription.
  std::vector<Outgoing> Route(uint32_t channel, uint64_t stamp_ns, const std::vector<uint8_t>& payload) const;
  /// Channels some client is subscribed to.
  std::set<uint32_t> Wanted() const;
  /// A status message (level 0 info, 1 warning, 2 error) for one client.
  static Outgoing Status(uint64_t client, int level, const std::string& message);
  int clients() const;
  const std::vector<Channel>& channels() const { return channels_; }

 private:
  std::vector<Channel> channels_;
  std::set<uint32_t> channel_ids_;
  int max_clients_;
  std::string name_;
  mutable std::mutex mu_;
  // client -> subscription id -> channel
  std::map<uint64_t, std::map<uint32_t, uint32_t>> subs_;
};

}  // namespace hullpipe::bridge
