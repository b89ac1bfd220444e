#include "record_foxglove.h"

namespace hullpipe::record {
namespace {

WriterOptions McapZstd() {
  WriterOptions o;
  o.storage = Storage::kMcap;
  o.compression = Compression::kZstd;
  return o;
}

}  // namespace

FoxgloveExport::FoxgloveExport(const std::string& path, const dds::Participant& participant)
    : path_(path), w_(path, McapZstd()), deriver_(participant, [this](foxglove::Message m) { Write(m); }) {
  w_.SetMeta("foxglove_channels", "derived by hullpipe_record export --foxglove (docs/recording.md)");
}

void FoxgloveExport::Appended() {
  if (++appended_ % 64 == 0) w_.Commit();
}

bool FoxgloveExport::Add(const TopicInfo& topic, const Sample& sample) {
  auto it = ids_.find(topic.name);
  if (it == ids_.end()) it = ids_.emplace(topic.name, w_.AddTopic(topic)).first;
  Sample s = sample;
  s.topic_id = it->second;
  log_ns_ = s.arrival_ns;
  w_.Append(s);
  Appended();
  return deriver_.Add(topic.type, sample.data, sample.arrival_ns);
}

void FoxgloveExport::Write(const foxglove::Message& m) {
  auto it = ids_.find(m.topic);
  if (it == ids_.end()) {
    TopicInfo t;
    t.name = m.topic;
    t.type = m.schema_name;
    t.type_description = foxglove::SchemaText(m.schema_name);
    t.schema_encoding = "jsonschema";
    t.message_encoding = "json";
    it = ids_.emplace(m.topic, w_.AddTopic(t)).first;
  }
  Sample s;
  s.topic_id = it->second;
  s.arrival_ns = log_ns_ >= 0 ? log_ns_ : m.stamp_ns;
  s.source_ns = m.stamp_ns;
  s.data.assign(m.json.begin(), m.json.end());
  w_.Append(s);
  ++counts_[m.topic];
  Appended();
}

}  // namespace hullpipe::record
