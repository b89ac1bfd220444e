#include "hullpipe/foxglove/bridge_channels.h"

#include <stdexcept>

#include "hullpipe/foxglove/channels.h"

namespace hullpipe::foxglove {

size_t BridgeChannels::TypeIndex(const std::string& type_name) const {
  for (size_t i = 0; i < types_.size(); ++i)
    if (types_[i].type_name == type_name) return i;
  throw std::logic_error("no hullpipe type " + type_name);
}

BridgeChannels::BridgeChannels(const std::vector<dds::KnownType>& types) : types_(types) {
  camera_info_ = TypeIndex("hullpipe::msg::CameraInfo");
  for (size_t i = 0; i < types_.size(); ++i)
    channels_.push_back(
        {uint32_t(i + 1), types_[i].topic_name, "cdr", types_[i].type_name, dds::IdlText(), "omgidl"});
  next_id_ = uint32_t(types_.size() + 1);
  for (const ChannelSpec& c : FixedChannels()) channels_.push_back(AddViewable(c.topic, c.schema_name, c.schema));
}

bridge::Channel BridgeChannels::AddViewable(const std::string& topic, const std::string& schema_name,
                                            const std::string& schema) {
  const uint32_t id = next_id_++;
  viewable_[topic] = id;
  for (const std::string& t : SourceTypes(topic)) sources_[id].push_back(TypeIndex(t));
  return bridge::Channel{id, topic, "json", schema_name, schema, "jsonschema"};
}

std::optional<uint32_t> BridgeChannels::ChannelOf(const std::string& topic, std::vector<bridge::Channel>* added) {
  const auto it = viewable_.find(topic);
  if (it != viewable_.end()) return it->second;
  const int64_t cam = CameraOfTopic(topic);
  if (cam < 0 || cameras_.count(cam)) return std::nullopt;
  if (cameras_.size() >= kMaxCameras) {
    if (refused_++ == 0) first_refused_ = cam;
    return std::nullopt;
  }
  cameras_.insert(cam);
  for (const ChannelSpec& c : CameraChannels(uint32_t(cam))) {
    channels_.push_back(AddViewable(c.topic, c.schema_name, c.schema));
    added->push_back(channels_.back());
  }
  const auto now = viewable_.find(topic);
  if (now == viewable_.end()) return std::nullopt;  // a camera topic that is not one of its channels
  return now->second;
}

BridgeChannels::Needs BridgeChannels::ReadersFor(const std::set<uint32_t>& wanted) const {
  Needs n;
  for (const uint32_t ch : wanted) {
    if (ch >= 1 && ch <= types_.size()) n.raw.insert(ch - 1);
    const auto src = sources_.find(ch);
    if (src != sources_.end()) n.derived.insert(src->second.begin(), src->second.end());
  }
  n.derived.erase(camera_info_);  // read always (the cameras' channels and latched state come from it)
  n.all = n.raw;
  n.all.insert(n.derived.begin(), n.derived.end());
  return n;
}

bool BridgeChannels::IsWanted(const std::string& topic, const std::set<uint32_t>& wanted) const {
  const auto it = viewable_.find(topic);
  return it != viewable_.end() && wanted.count(it->second) > 0;
}

}  // namespace hullpipe::foxglove
