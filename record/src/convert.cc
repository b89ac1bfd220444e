#include "hullpipe/record/convert.h"

#include <map>
#include <vector>

#include "hullpipe/record/storage.h"

namespace hullpipe::record {
namespace {

// A sample's identity across storages (ids differ): its topic's name, both
// times and its bytes.
uint32_t SampleCrc(const std::string& topic, const Sample& s) {
  return RowCrc(0, s.source_ns, s.arrival_ns, s.data.data(), s.data.size()) ^
         RowCrc(0, 0, 0, reinterpret_cast<const uint8_t*>(topic.data()), topic.size());
}

}  // namespace

ConvertReport Convert(const std::string& in, const std::string& out, const WriterOptions& options) {
  options.Check();
  const Storage storage = options.storage.value_or(StorageForPath(out));
  options.Check(storage);
  ConvertReport rep;
  const RecordingReader r(in);
  const RecordingInfo before = r.Info();
  rep.input_storage = before.storage;
  rep.output_storage = StorageName(storage);
  rep.input_damage = before.damage;
  std::map<int64_t, std::string> names;
  for (const auto& t : r.topics()) names[t.id] = t.name;
  std::vector<uint32_t> crcs;
  {
    WriterOptions o = options;
    o.storage = storage;
    RecordingWriter w(out, o);
    for (const auto& [k, v] : before.meta)
      if (k != "format" && k != "compression" && k != "closed_ns") w.SetMeta(k, v);
    w.SetMeta("converted_from", in);
    // A storage of CDR alone (SQLite) does not take an MCAP file's other
    // channels (the viewable JSON ones `export --foxglove` adds).
    const bool cdr_only = StorageKindOf(storage).cdr_only;
    std::map<int64_t, int64_t> out_id;
    for (const auto& t : r.topics()) {
      if (cdr_only && t.message_encoding != "cdr") {
        rep.skipped_topics.push_back(t.name);
        continue;
      }
      out_id[t.id] = w.AddTopic(t);
    }
    rep.topics = int64_t(out_id.size());
    const int64_t damaged_before = r.damaged_samples();
    Sample c;
    std::vector<int64_t> copied;
    for (const auto& [in_id, id] : out_id) copied.push_back(in_id);
    r.ForEach([&](const Sample& s) {
      c = s;
      c.topic_id = out_id.at(s.topic_id);
      w.Append(c);
      crcs.push_back(SampleCrc(names.at(s.topic_id), s));
      if (++rep.samples % 256 == 0) w.Commit();
      return true;
    }, copied);
    rep.damaged_samples = r.damaged_samples() - damaged_before;
    w.Commit();
  }
  const RecordingReader back(out);
  std::map<int64_t, std::string> back_names;
  for (const auto& t : back.topics()) back_names[t.id] = t.name;
  size_t i = 0;
  back.ForEach([&](const Sample& s) {
    if (i >= crcs.size() || crcs[i] != SampleCrc(back_names.at(s.topic_id), s)) ++rep.differ;
    ++i;
    return true;
  });
  if (i < crcs.size()) rep.differ += int64_t(crcs.size() - i);
  return rep;
}

}  // namespace hullpipe::record
