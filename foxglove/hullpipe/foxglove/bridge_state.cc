#include "hullpipe/foxglove/bridge_state.h"

#include <algorithm>

#include <nlohmann/json.hpp>

namespace hullpipe::bridge {

using nlohmann::json;

BridgeState::BridgeState(std::vector<Channel> channels, int max_clients, std::string name)
    : channels_(std::move(channels)), max_clients_(std::max(1, max_clients)), name_(std::move(name)) {
  for (const auto& c : channels_) channel_ids_.insert(c.id);
}

std::string BridgeState::Accept(const std::vector<std::string>& subprotocols, int handshaking, std::string* why) const {
  std::string chosen;
  for (const char* mine : {"foxglove.sdk.v1", "foxglove.websocket.v1"})
    if (chosen.empty() && std::find(subprotocols.begin(), subprotocols.end(), mine) != subprotocols.end())
      chosen = mine;
  if (chosen.empty()) {
    *why = "no subprotocol the bridge speaks (foxglove.sdk.v1, foxglove.websocket.v1)";
    return "";
  }
  if (clients() + handshaking >= max_clients_) {
    *why = "already " + std::to_string(max_clients_) + " clients (--max-clients)";
    return "";
  }
  return chosen;
}

std::vector<Outgoing> BridgeState::Open(uint64_t client, const std::string& session_id) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    subs_[client];
  }
  json info = {{"op", "serverInfo"},
               {"name", name_},
               {"capabilities", json::array()},  // no clientPublish: clients cannot publish
               {"supportedEncodings", json::array()},
               {"metadata", json::object()},
               {"sessionId", session_id}};
  std::lock_guard<std::mutex> lock(mu_);
  return {{client, false, info.dump()}, {client, false, AdvertiseText(channels_)}};
}

std::string BridgeState::AdvertiseText(const std::vector<Channel>& list) const {
  json channels = json::array();
  for (const auto& c : list)
    channels.push_back({{"id", c.id},
                        {"topic", c.topic},
                        {"encoding", c.encoding},
                        {"schemaName", c.schema_name},
                        {"schema", c.schema},
                        {"schemaEncoding", c.schema_encoding}});
  return json{{"op", "advertise"}, {"channels", channels}}.dump();
}

std::vector<Outgoing> BridgeState::Advertise(const std::vector<Channel>& more) {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<Channel> added;
  for (const auto& c : more)
    if (channel_ids_.insert(c.id).second) {
      channels_.push_back(c);
      added.push_back(c);
    }
  std::vector<Outgoing> out;
  if (added.empty()) return out;
  const std::string text = AdvertiseText(added);
  for (const auto& [client, subs] : subs_) out.push_back({client, false, text});
  return out;
}

std::vector<Channel> BridgeState::channels() const {
  std::lock_guard<std::mutex> lock(mu_);
  return channels_;
}

bool BridgeState::Latch(uint32_t channel, const std::string& key, uint64_t stamp_ns, std::vector<uint8_t> payload) {
  std::lock_guard<std::mutex> lock(mu_);
  auto& keys = latched_[channel];
  auto it = keys.find(key);
  if (it == keys.end()) {
    if (keys.size() >= 4096) return false;
    it = keys.emplace(key, Latched{}).first;
  }
  it->second = Latched{stamp_ns, std::move(payload)};
  return true;
}

std::string BridgeState::Data(uint32_t sub, uint64_t stamp_ns, const std::vector<uint8_t>& payload) const {
  std::string p(1 + 4 + 8 + payload.size(), '\0');
  p[0] = char(0x01);  // message data
  for (int i = 0; i < 4; ++i) p[size_t(1 + i)] = char(sub >> (8 * i));
  for (int i = 0; i < 8; ++i) p[size_t(5 + i)] = char(stamp_ns >> (8 * i));
  std::copy(payload.begin(), payload.end(), p.begin() + 13);
  return p;
}

void BridgeState::Close(uint64_t client) {
  std::lock_guard<std::mutex> lock(mu_);
  subs_.erase(client);
}

Outgoing BridgeState::Status(uint64_t client, int level, const std::string& message) {
  return {client, false, json{{"op", "status"}, {"level", level}, {"message", message}}.dump()};
}

namespace {

// The deepest nesting of [ and { outside strings, stopping past `limit`.
int JsonDepth(const std::string& text, int limit) {
  int depth = 0, deepest = 0;
  bool in_string = false, escaped = false;
  for (const char c : text) {
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
      if (deepest > limit) return deepest;
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return deepest;
}

std::string Echo(const std::string& s) {
  return s.size() <= BridgeState::kMaxEcho ? s : s.substr(0, BridgeState::kMaxEcho) + "...";
}

}  // namespace

std::vector<Outgoing> BridgeState::OnText(uint64_t client, const std::string& text) {
  if (text.size() > kMaxTextBytes)
    return {Status(client, 2, "a message of " + std::to_string(text.size()) + " bytes; at most " +
                                  std::to_string(kMaxTextBytes) + " are read")};
  if (JsonDepth(text, kMaxJsonDepth) > kMaxJsonDepth)
    return {Status(client, 2, "JSON nested deeper than " + std::to_string(kMaxJsonDepth) + " levels")};
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object() || !j.contains("op") || !j["op"].is_string())
    return {Status(client, 2, "not a JSON object with an 'op'")};
  const std::string op = j["op"];
  std::vector<Outgoing> out;
  std::lock_guard<std::mutex> lock(mu_);
  auto& mine = subs_[client];
  if (op == "subscribe") {
    if (!j.contains("subscriptions") || !j["subscriptions"].is_array())
      return {Status(client, 2, "subscribe without a 'subscriptions' array")};
    for (const auto& s : j["subscriptions"]) {
      if (!s.is_object() || !s.contains("id") || !s.contains("channelId") || !s["id"].is_number_unsigned() ||
          !s["channelId"].is_number_unsigned()) {
        out.push_back(Status(client, 2, "a subscription needs unsigned 'id' and 'channelId'"));
        continue;
      }
      const uint64_t id = s["id"], channel = s["channelId"];
      if (id > UINT32_MAX) {
        out.push_back(Status(client, 2, "subscription id " + std::to_string(id) + " is past 2^32 - 1"));
        continue;
      }
      if (channel > UINT32_MAX || !channel_ids_.count(uint32_t(channel))) {
        out.push_back(Status(client, 2, "no channel " + std::to_string(channel)));
        continue;
      }
      if (mine.count(uint32_t(id))) {
        out.push_back(Status(client, 2, "subscription " + std::to_string(id) + " exists"));
        continue;
      }
      const auto same = std::find_if(mine.begin(), mine.end(), [&](const auto& kv) { return kv.second == channel; });
      if (same != mine.end()) {
        out.push_back(Status(client, 2, "channel " + std::to_string(channel) + " is already subscribed as " +
                                            std::to_string(same->first) + " (one subscription a channel)"));
        continue;
      }
      mine[uint32_t(id)] = uint32_t(channel);
      const auto latched = latched_.find(uint32_t(channel));
      if (latched != latched_.end())
        for (const auto& [key, l] : latched->second)
          out.push_back({client, true, Data(uint32_t(id), l.stamp_ns, l.payload)});
    }
  } else if (op == "unsubscribe") {
    if (!j.contains("subscriptionIds") || !j["subscriptionIds"].is_array())
      return {Status(client, 2, "unsubscribe without a 'subscriptionIds' array")};
    for (const auto& id : j["subscriptionIds"])
      if (id.is_number_unsigned()) mine.erase(uint32_t(id.get<uint64_t>()));
  } else if (op == "advertise" || op == "unadvertise") {
    out.push_back(Status(client, 2, "client publishing is not enabled on this bridge"));
  } else {
    out.push_back(Status(client, 1, "operation '" + Echo(op) + "' is not supported by hullpipe_bridge"));
  }
  return out;
}

std::vector<Outgoing> BridgeState::Route(uint32_t channel, uint64_t stamp_ns,
                                         const std::vector<uint8_t>& payload) const {
  std::vector<Outgoing> out;
  std::lock_guard<std::mutex> lock(mu_);
  for (const auto& [client, subs] : subs_)
    for (const auto& [sub, ch] : subs)
      if (ch == channel) out.push_back({client, true, Data(sub, stamp_ns, payload)});
  return out;
}

std::set<uint32_t> BridgeState::Wanted() const {
  std::set<uint32_t> out;
  std::lock_guard<std::mutex> lock(mu_);
  for (const auto& [client, subs] : subs_)
    for (const auto& [sub, ch] : subs) out.insert(ch);
  return out;
}

int BridgeState::clients() const {
  std::lock_guard<std::mutex> lock(mu_);
  return int(subs_.size());
}

}  // namespace hullpipe::bridge
