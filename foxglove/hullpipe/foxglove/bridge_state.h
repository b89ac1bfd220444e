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
/// type's omgidl schema), or a viewable channel (json, a jsonschema schema).
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
  /// to refuse (none spoken, or max_clients connected or accepted in handshakes
  /// not yet open, `handshaking` of them: 500 concurrent handshakes once got 128
  /// clients past --max-clients 8; *why says which).
  std::string Accept(const std::vector<std::string>& subprotocols, int handshaking, std::string* why) const;
  /// A client connected: the serverInfo and advertise messages to send it.
  std::vector<Outgoing> Open(uint64_t client, const std::string& session_id);
  void Close(uint64_t client);
  /// Channels that appear while clients are connected (a camera's viewable
  /// channels when its calibration arrives): added, and one advertise message
  /// for each connected client. Ids must be new (a channel with an id already
  /// advertised is ignored).
  std::vector<Outgoing> Advertise(const std::vector<Channel>& more);
  /// A text message from a client: subscribe / unsubscribe (others, and client
  /// publishing, answered with a status error); what to send back. A new
  /// subscription is sent its channel's latched messages at once. Bounds, each
  /// answered with one status error: text over kMaxTextBytes or nested deeper
  /// than kMaxJsonDepth is refused before it is parsed; a channel id or
  /// subscription id past 2^32 - 1 is no channel (2^32 + 3 was taken as 3); a
  /// client holds at most one subscription per channel (100,000 subscriptions
  /// to the image channel once copied each image 100,000 times); replies name
  /// at most kMaxEcho bytes of what the client sent.
  std::vector<Outgoing> OnText(uint64_t client, const std::string& text);
  static constexpr size_t kMaxTextBytes = size_t(1) << 20;
  static constexpr int kMaxJsonDepth = 8;
  static constexpr size_t kMaxEcho = 64;
  /// Keeps `payload` as the latest message of (channel, key): state a late
  /// subscriber needs (a calibration, a camera's transform, a model part), sent
  /// to each new subscription of the channel. At most 4096 keys per channel
  /// (further keys are not kept; false).
  bool Latch(uint32_t channel, const std::string& key, uint64_t stamp_ns, std::vector<uint8_t> payload);
  /// A sample of channel `channel` received at `stamp_ns`: one binary message
  /// (opcode 1, subscription id, timestamp, payload) per subscription.
  std::vector<Outgoing> Route(uint32_t channel, uint64_t stamp_ns, const std::vector<uint8_t>& payload) const;
  /// Channels some client is subscribed to.
  std::set<uint32_t> Wanted() const;
  /// A status message (level 0 info, 1 warning, 2 error) for one client.
  static Outgoing Status(uint64_t client, int level, const std::string& message);
  int clients() const;
  std::vector<Channel> channels() const;

 private:
  std::string Data(uint32_t subscription, uint64_t stamp_ns, const std::vector<uint8_t>& payload) const;
  std::string AdvertiseText(const std::vector<Channel>& channels) const;
  std::vector<Channel> channels_;
  std::set<uint32_t> channel_ids_;
  struct Latched {
    uint64_t stamp_ns = 0;
    std::vector<uint8_t> payload;
  };
  std::map<uint32_t, std::map<std::string, Latched>> latched_;  // channel -> key -> latest
  int max_clients_;
  std::string name_;
  mutable std::mutex mu_;
  // client -> subscription id -> channel
  std::map<uint64_t, std::map<uint32_t, uint32_t>> subs_;
};

}  // namespace hullpipe::bridge
