// The MCAP storage's reader (mcap_format.h has the file's layout): the summary
// where the file has one, else a linear scan of the top-level records (a
// writer killed leaves no summary or footer); each chunk decoded at most once
// for info's questions; the bounds of docs/recording.md "Bounds" kept.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <queue>
#include <set>

#include "hullpipe/record/storage.h"
#include "mcap_compression.h"
#include "mcap_format.h"

namespace hullpipe::record {
namespace mcap {
namespace {

// The chunks held at once while ForEach merges them by log time: past this, the
// held chunks are given out before the next is decoded (chunks overlapping in
// time by more than this are merged only within each group).
constexpr uint64_t kMergeBytes = uint64_t(512) << 20;
constexpr int kMaxFindings = 10;

class McapReader final : public StorageReader {
 public:
  explicit McapReader(const std::string& path);
  ~McapReader() override { ::close(fd_); }
  const std::string& path() const override { return path_; }
  Storage storage() const override { return Storage::kMcap; }
  const std::vector<TopicInfo>& topics() const override { return topics_; }
  const std::map<std::string, std::string>& meta() const override { return meta_; }
  std::string format() const override { return "mcap"; }
  bool interrupted() const override { return !has_footer_ || meta_.count("interrupted"); }
  bool ForEach(const std::optional<std::set<int64_t>>& ids, const std::function<bool(const Sample&)>& f,
               int64_t* damaged) const override;
  std::optional<int64_t> ArrivalBound(bool max, const std::optional<std::set<int64_t>>& ids) const override;
  std::string QuickCheck() const override;
  std::map<int64_t, TopicCount> Counts() const override;
  std::optional<int64_t> DamagedSamples() const override;
  int64_t FileBytes() const override { return int64_t(size_); }

 private:
  // A chunk, or one message outside chunks (a "loose" unit).
  struct Unit {
    uint64_t offset = 0;  // of the record
    bool chunk = true;
    uint64_t start_ns = 0, end_ns = 0;
    uint64_t uncompressed_size = 0;
    uint32_t crc = 0;
    std::string compression;
    uint64_t records_offset = 0, records_size = 0;  // the records field in the file
    // From the Message Index records after the chunk: per channel, log times.
    std::map<uint16_t, std::vector<uint64_t>> index;
    bool indexed = false;
    std::string refused;  // why it is not decoded (set at open: over a bound), or empty
  };
  // A message's place in its unit's decoded records (24 bytes: a chunk of
  // 256 MiB of the smallest messages holds 8.7 M of them).
  struct Msg {
    uint64_t log_ns;
    uint32_t offset;  // of its record in the unit's records: ties go in write order
    uint32_t slot;    // its unit's place in ForEach's load order
    uint32_t unit;    // its unit's place in the file: ties go in write order
    uint16_t channel;
  };
  // The message record at `offset` of `records`: its publish time and data.
  static void MessageAt(const std::vector<uint8_t>& records, uint32_t offset, uint64_t* pub_ns, const uint8_t** data,
                        size_t* size);
  std::vector<uint8_t> Read(uint64_t at, uint64_t n) const;
  void Finding(const std::string& what) {
    if (int(findings_.size()) < kMaxFindings) findings_.push_back(what);
  }
  void Scan();
  void ReadSummary();
  void AddSchema(In& in, uint64_t at);
  void AddChannel(In& in, uint64_t at);
  // The unit's messages (all channels), decoded; false (with why) if the chunk
  // does not decompress or check.
  // Schema and Channel records inside it go to `collect` where given (at open).
  bool Decode(const Unit& u, std::vector<uint8_t>* records, std::vector<Msg>* out, std::string* why,
              McapReader* collect = nullptr) const;
  // Marks the units past kMaxChunkBytes or the file's expansion bound as refused.
  void Bound();
  bool Wanted(const Unit& u, const std::optional<std::set<int64_t>>& ids) const;
  // What one decode of a unit tells, kept: QuickCheck, Counts, ArrivalBound and
  // DamagedSamples each once decoded every chunk (info: five passes; a 4.3-MB
  // file of 64-MiB chunks took 136 s), now `info` decodes each chunk once.
  struct Survey {
    bool done = false, ok = false;
    std::string why;
    struct PerChannel {
      int64_t count = 0, bytes = 0, stored = 0;
      uint64_t min_log = UINT64_MAX, max_log = 0;
    };
    std::map<uint16_t, PerChannel> channels;  // every channel id its messages name
  };
  // `collect`: as Decode's (at open, a file without a summary).
  const Survey& SurveyOf(size_t unit, McapReader* collect = nullptr) const;
  void Fill(Survey* s, const Unit& u, const std::vector<uint8_t>& records, const std::vector<Msg>& msgs) const;
  int64_t IndexedCount(const Unit& u, const std::optional<std::set<int64_t>>& ids) const;

  std::string path_;
  int fd_ = -1;
  uint64_t size_ = 0;
  bool has_footer_ = false;
  uint64_t data_end_ = 0;  // where the data section ends (the scan stops)
  struct Schema {
    std::string name, encoding, data;
  };
  std::map<uint16_t, Schema> schemas_;
  struct Channel {
    uint16_t schema;
    std::string topic, encoding;
    std::map<std::string, std::string> metadata;
  };
  std::map<uint16_t, Channel> channels_;
  std::vector<Unit> units_;
  std::vector<TopicInfo> topics_;
  std::set<int64_t> channel_ids_;
  std::map<std::string, std::string> meta_;
  std::vector<std::string> findings_;
  mutable std::mutex survey_mu_;
  mutable std::vector<Survey> surveys_;   // by unit, filled as chunks are decoded
  mutable Survey loose_;                  // the last loose message's, valid until the next call
  mutable std::vector<uint8_t> scratch_;  // the surveys' records buffer, reused (no page faults per chunk)
};

std::vector<uint8_t> McapReader::Read(uint64_t at, uint64_t n) const {
  if (at > size_ || n > size_ - at)
    throw RecordingError(path_ + ": a read of " + std::to_string(n) + " bytes at byte " + std::to_string(at) +
                         " runs past the end of the file (" + std::to_string(size_) + " bytes)");
  std::vector<uint8_t> b(n);
  size_t done = 0;
  while (done < n) {
    const ssize_t r = ::pread(fd_, b.data() + done, n - done, off_t(at + done));
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) throw RecordingError(path_ + ": read at byte " + std::to_string(at + done) + ": " +
                                     (r < 0 ? std::strerror(errno) : "end of file"));
    done += size_t(r);
  }
  return b;
}

McapReader::McapReader(const std::string& path) : path_(path) {
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) throw RecordingError(path + ": open: " + std::strerror(errno));
  try {
    struct stat st {};
    if (fstat(fd_, &st) != 0) throw RecordingError(path + ": fstat: " + std::strerror(errno));
    size_ = uint64_t(st.st_size);
    if (size_ < 8 || std::memcmp(Read(0, 8).data(), kMagic, 8) != 0)
      throw RecordingError(path + ": not an MCAP file (bad magic)");
    // The footer: 29 bytes and the magic at the end of a file that was closed.
    if (size_ >= 8 + 9 + 29 + 8) {
      const auto tail = Read(size_ - 37, 37);
      if (std::memcmp(tail.data() + 29, kMagic, 8) == 0 && tail[0] == kFooter) {
        In in{tail.data() + 1, 28};
        has_footer_ = in.u64("length") == 20;
      }
    }
    Scan();
    Bound();
    ReadSummary();
    // Topics: every channel, its schema named; the QoS from metadata 'qos'.
    for (const auto& [id, c] : channels_) {
      TopicInfo t;
      t.id = id;
      t.name = c.topic;
      if (c.schema != 0) {
        const auto s = schemas_.find(c.schema);
        if (s == schemas_.end())
          throw RecordingError(path + ": channel " + std::to_string(id) + " ('" + c.topic + "') names schema " +
                               std::to_string(c.schema) + ", which does not exist in the file");
        t.type = s->second.name;
        t.schema_encoding = s->second.encoding;
        if (!s->second.encoding.empty()) t.type_description = s->second.data;
      }
      if (t.type.empty())
        throw RecordingError(path + ": channel " + std::to_string(id) + " ('" + c.topic +
                             "') has no schema, so no type to replay it as");
      t.message_encoding = c.encoding;
      const auto q = c.metadata.find("qos");
      if (q != c.metadata.end()) {
        try {
          const YAML::Node y = YAML::Load(q->second);
          if (y["reliability"]) t.reliable = y["reliability"].as<bool>();
          if (y["durability"]) t.transient_local = y["durability"].as<bool>();
          if (y["keyed"]) t.keyed = y["keyed"].as<bool>();
          if (y["depth"]) t.depth = std::clamp(y["depth"].as<int32_t>(), 1, 100000);
        } catch (const YAML::Exception& e) {
          throw RecordingError(path + ": channel " + std::to_string(id) + " ('" + c.topic +
                               "'): metadata 'qos' is not the YAML of a QoS: " + e.what());
        }
      }
      topics_.push_back(t);
      channel_ids_.insert(id);
    }
    // What the writer was asked for (a chunk that did not shrink is stored as it
    // is); for other writers' files, what the chunks use.
    std::set<std::string> compressions;
    for (const auto& u : units_)
      if (u.chunk) compressions.insert(u.compression.empty() ? "none" : u.compression);
    if (meta_.count("compression")) {
    } else if (!compressions.empty()) {
      std::string c;
      for (const auto& x : compressions) c += (c.empty() ? "" : ", ") + x;
      meta_["compression"] = c;
    } else {
      meta_["compression"] = "none";
    }
  } catch (...) {
    ::close(fd_);
    fd_ = -1;
    throw;
  }
}

void McapReader::AddSchema(In& in, uint64_t at) {
  const uint16_t id = in.u16("schema id");
  Schema s{in.str("schema name"), in.str("schema encoding"), ""};
  In d = in.sub(in.u32("schema data"), "schema data");
  s.data.assign(reinterpret_cast<const char*>(d.p), d.n);
  if (id == 0) return;  // the spec: invalid, ignored
  auto [it, added] = schemas_.emplace(id, s);
  if (!added && (it->second.name != s.name || it->second.data != s.data))
    Finding("schema " + std::to_string(id) + " at byte " + std::to_string(at) + " differs from its earlier record");
}

void McapReader::AddChannel(In& in, uint64_t at) {
  const uint16_t id = in.u16("channel id");
  Channel c;
  c.schema = in.u16("schema id");
  c.topic = in.str("topic");
  c.encoding = in.str("message encoding");
  c.metadata = in.map("channel metadata");
  auto [it, added] = channels_.emplace(id, c);
  if (!added && (it->second.topic != c.topic || it->second.schema != c.schema))
    Finding("channel " + std::to_string(id) + " at byte " + std::to_string(at) + " differs from its earlier record");
}

void McapReader::Scan() {
  // The header.
  uint64_t at = 8;
  {
    if (size_ < at + 9) throw RecordingError(path_ + ": MCAP file without a Header record (cut at byte " +
                                             std::to_string(size_) + ")");
    const auto h = Read(at, 9);
    In in{h.data(), 9};
    if (in.u8("opcode") != kHeader) throw RecordingError(path_ + ": the first MCAP record is not a Header");
    const uint64_t len = in.u64("length");
    if (len > size_ - at - 9)
      throw RecordingError(path_ + ": the Header record claims " + std::to_string(len) + " bytes, past the end");
    at += 9 + len;
  }
  const uint64_t limit = size_ - (has_footer_ ? 37 : 0);
  Unit* last_chunk = nullptr;  // message indexes follow their chunk
  while (at < limit) {
    // A cut: the chunk before it may have lost some of its message indexes, so
    // none of them is trusted (the chunk is decoded to know what it holds).
    auto cut = [&] {
      if (last_chunk) {
        last_chunk->indexed = false;
        last_chunk->index.clear();
      }
    };
    if (limit - at < 9) {
      Finding("cut at byte " + std::to_string(at) + " inside a record's opcode and length");
      cut();
      break;
    }
    const auto head = Read(at, 9);
    In h{head.data(), 9};
    const uint8_t op = h.u8("opcode");
    const uint64_t len = h.u64("length");
    if (len > limit - at - 9) {
      Finding("the record at byte " + std::to_string(at) + " (opcode " + std::to_string(op) + ") claims " +
              std::to_string(len) + " bytes, past the end of the file (" + std::to_string(size_) + " bytes)");
      cut();
      break;
    }
    const uint64_t content = at + 9;
    try {
      if (op == kDataEnd || op == kFooter) {
        data_end_ = at;
        break;
      }
      if (op == kChunk) {
        // The fixed fields and the compression string, not the records.
        const auto fixed = Read(content, std::min<uint64_t>(len, 4096));
        In in{fixed.data(), fixed.size()};
        Unit u;
        u.offset = at;
        u.start_ns = in.u64("message_start_time");
        u.end_ns = in.u64("message_end_time");
        u.uncompressed_size = in.u64("uncompressed_size");
        u.crc = in.u32("uncompressed_crc");
        u.compression = in.str("compression");
        u.records_size = in.u64("records length");
        u.records_offset = content + in.at;
        if (u.records_size > len - in.at) throw Malformed("its records run past the record's end");
        units_.push_back(std::move(u));
        last_chunk = &units_.back();
      } else if (op == kMessageIndex) {
        if (len > (uint64_t(256) << 20)) throw Malformed("a message index of " + std::to_string(len) + " bytes");
        const auto b = Read(content, len);
        In in{b.data(), b.size()};
        const uint16_t ch = in.u16("channel id");
        In entries = in.sub(in.u32("records"), "records");
        if (last_chunk) {
          auto& times = last_chunk->index[ch];
          while (!entries.done()) {
            times.push_back(entries.u64("log_time"));
            entries.u64("offset");
          }
          last_chunk->indexed = true;
        }
      } else {
        last_chunk = nullptr;
        if (op == kSchema || op == kChannel || op == kMetadata || op == kMessage) {
          if (len > (uint64_t(64) << 20) && op != kMessage)
            throw Malformed("a record of " + std::to_string(len) + " bytes");
          const auto b = Read(content, op == kMessage ? std::min<uint64_t>(len, 22) : len);
          In in{b.data(), b.size()};
          if (op == kSchema) AddSchema(in, at);
          else if (op == kChannel) AddChannel(in, at);
          else if (op == kMetadata) {
            const std::string name = in.str("metadata name");
            auto m = in.map("metadata");
            if (name == kMetaName)
              for (auto& [k, v] : m) meta_[k] = std::move(v);
          } else {
            Unit u;
            u.offset = at;
            u.chunk = false;
            in.u16("channel id");
            in.u32("sequence");
            u.start_ns = u.end_ns = in.u64("log_time");
            u.records_offset = at;
            u.records_size = 9 + len;
            units_.push_back(std::move(u));
          }
        }
      }
    } catch (const Malformed& e) {
      Finding("the record at byte " + std::to_string(at) + " (opcode " + std::to_string(op) + ") is malformed: " +
              e.what());
      if (op == kSchema || op == kChannel)
        throw RecordingError(path_ + ": " + findings_.back());
    }
    at = content + len;
  }
  if (!data_end_) data_end_ = at;
}

void McapReader::Bound() {
  uint64_t declared = 0;
  bool said = false;
  for (auto& u : units_) {
    const uint64_t size = u.chunk ? u.uncompressed_size : u.records_size;
    if (size > kMaxChunkBytes) {
      u.refused = "the " + std::string(u.chunk ? "chunk" : "message") + " at byte " + std::to_string(u.offset) +
                  " has a declared size of " + std::to_string(size) + " bytes, over the " +
                  std::to_string(kMaxChunkBytes >> 20) + " MiB a chunk this reader holds";
      Finding(u.refused);
      continue;
    }
    declared += size;
    if (!FileExpansionPlausible(declared, size_)) {
      u.refused = "the chunk at byte " + std::to_string(u.offset) + ": the file's chunks declare " +
                  std::to_string(declared) + " bytes uncompressed up to it, over 1024 times the file's " +
                  std::to_string(size_) + " bytes plus 64 MiB (a file made to expand); not decompressed";
      if (!said) Finding(u.refused + (units_.size() > 1 ? ", nor any chunk after it" : ""));
      said = true;
    }
  }
}

void McapReader::ReadSummary() {
  if (!has_footer_) {
    // The writer did not close the file (killed, or the disk filled): read by the
    // scan alone. Channels written inside chunks (by other writers) are found by decoding them.
    bool complete = true;
    for (const auto& u : units_) {
      if (!u.chunk) continue;
      if (!u.indexed) complete = false;
      for (const auto& [ch, t] : u.index)
        if (!channels_.count(ch)) complete = false;
    }
    if (!complete) {
      for (size_t i = 0; i < units_.size(); ++i)
        if (units_[i].chunk) SurveyOf(i, this);  // kept: info reads each chunk once
    }
    return;
  }
  const auto foot = Read(size_ - 37 + 9, 20);
  In f{foot.data(), 20};
  const uint64_t summary_start = f.u64("summary_start");
  f.u64("summary_offset_start");
  const uint32_t summary_crc = f.u32("summary_crc");
  if (summary_start == 0) return;
  if (summary_start < data_end_ || summary_start > size_ - 37) {
    Finding("the footer's summary_start " + std::to_string(summary_start) + " is outside the file's summary");
    return;
  }
  const uint64_t n = size_ - 37 - summary_start;
  if (n > (uint64_t(512) << 20)) {
    Finding("a summary of " + std::to_string(n) + " bytes");
    return;
  }
  const auto b = Read(summary_start, n);
  if (summary_crc != 0) {
    const auto footer_fields = Read(size_ - 37, 1 + 8 + 16);
    const uint32_t c = Crc(Crc(0, b.data(), b.size()), footer_fields.data(), footer_fields.size());
    if (c != summary_crc) Finding("the summary's CRC-32 does not match");
  }
  In in{b.data(), b.size()};
  try {
    while (!in.done()) {
      const uint8_t op = in.u8("opcode");
      In r = in.sub(in.u64("length"), "record");
      if (op == kSchema) AddSchema(r, summary_start + in.at);
      else if (op == kChannel) AddChannel(r, summary_start + in.at);
    }
  } catch (const Malformed& e) {
    Finding(std::string("the summary is malformed: ") + e.what());
  }
}

bool McapReader::Decode(const Unit& u, std::vector<uint8_t>* records, std::vector<Msg>* out, std::string* why,
                        McapReader* collect) const {
  out->clear();
  records->clear();
  if (!u.refused.empty()) {
    *why = u.refused;
    return false;
  }
  if (u.chunk) {
    const auto stored = Read(u.records_offset, u.records_size);
    if (!Decompress(u.compression, stored.data(), stored.size(), u.uncompressed_size, records)) {
      *why = "the chunk at byte " + std::to_string(u.offset) + " does not " +
             (u.compression.empty() ? "hold its declared " + std::to_string(u.uncompressed_size) + " bytes"
                                    : "decompress (" + u.compression + ") to its declared " +
                                          std::to_string(u.uncompressed_size) + " bytes");
      return false;
    }
    if (u.crc != 0 && Crc(0, records->data(), records->size()) != u.crc) {
      *why = "the chunk at byte " + std::to_string(u.offset) + ": its records do not match their CRC-32";
      return false;
    }
  } else {
    *records = Read(u.records_offset, u.records_size);
  }
  In in{records->data(), records->size()};
  try {
    while (!in.done()) {
      const size_t at = in.at;
      const uint8_t op = in.u8("opcode");
      In r = in.sub(in.u64("length"), "record");
      if (op == kMessage) {
        Msg m;
        m.channel = r.u16("channel id");
        r.u32("sequence");
        m.log_ns = r.u64("log_time");
        r.u64("publish_time");
        m.offset = uint32_t(at);  // records are at most kMaxChunkBytes
        m.slot = m.unit = 0;
        out->push_back(m);
      } else if (op == kSchema && collect) {
        collect->AddSchema(r, u.offset);
      } else if (op == kChannel && collect) {
        collect->AddChannel(r, u.offset);
      }
    }
  } catch (const Malformed& e) {
    *why = "the chunk at byte " + std::to_string(u.offset) + " holds a malformed record: " + e.what();
    return false;
  }
  return true;
}

void McapReader::MessageAt(const std::vector<uint8_t>& records, uint32_t offset, uint64_t* pub_ns,
                           const uint8_t** data, size_t* size) {
  // Checked when decoded: opcode, length, channel, sequence, log and publish times.
  In in{records.data() + offset, records.size() - offset};
  in.u8("opcode");
  const uint64_t len = in.u64("length");
  in.u16("channel id");
  in.u32("sequence");
  in.u64("log_time");
  *pub_ns = in.u64("publish_time");
  *data = records.data() + offset + 9 + 22;
  *size = size_t(len - 22);
}

void McapReader::Fill(Survey* s, const Unit& u, const std::vector<uint8_t>& records,
                      const std::vector<Msg>& msgs) const {
  s->ok = true;
  uint64_t total = 0;
  std::vector<size_t> sizes(msgs.size());
  for (size_t k = 0; k < msgs.size(); ++k) {
    uint64_t pub;
    const uint8_t* data;
    MessageAt(records, msgs[k].offset, &pub, &data, &sizes[k]);
    total += sizes[k];
  }
  // A chunk's stored bytes shared out by its messages' sizes.
  const double stored = u.chunk ? double(u.records_size) : double(total);
  for (size_t k = 0; k < msgs.size(); ++k) {
    const Msg& m = msgs[k];
    auto& c = s->channels[m.channel];
    ++c.count;
    c.bytes += int64_t(sizes[k]);
    c.stored += total ? int64_t(stored * double(sizes[k]) / double(total) + 0.5) : 0;
    c.min_log = std::min(c.min_log, m.log_ns);
    c.max_log = std::max(c.max_log, m.log_ns);
  }
}

const McapReader::Survey& McapReader::SurveyOf(size_t unit, McapReader* collect) const {
  std::lock_guard<std::mutex> lock(survey_mu_);
  if (surveys_.size() != units_.size()) surveys_.resize(units_.size());
  // Chunks' surveys are kept; a loose message's is made again when asked (a
  // file of millions of loose messages would otherwise keep millions).
  Survey& s = units_[unit].chunk ? surveys_[unit] : loose_;
  if (units_[unit].chunk && s.done) return s;
  s = Survey{};
  std::vector<Msg> msgs;
  s.done = true;
  if (Decode(units_[unit], &scratch_, &msgs, &s.why, collect)) Fill(&s, units_[unit], scratch_, msgs);
  if (scratch_.capacity() > (uint64_t(128) << 20)) std::vector<uint8_t>().swap(scratch_);  // keep at most 128 MiB
  return s;
}

std::optional<int64_t> McapReader::DamagedSamples() const {
  int64_t n = 0;
  for (size_t i = 0; i < units_.size(); ++i) {
    const Survey& s = SurveyOf(i);
    if (!s.ok) {
      n += IndexedCount(units_[i], std::nullopt);
      continue;
    }
    for (const auto& [ch, c] : s.channels)
      if (!channel_ids_.count(ch)) n += c.count;  // messages of no channel
  }
  return n;
}

bool McapReader::Wanted(const Unit& u, const std::optional<std::set<int64_t>>& ids) const {
  if (!ids || !u.indexed) return true;
  for (const auto& [ch, t] : u.index)
    if (ids->count(ch)) return true;
  return false;
}

int64_t McapReader::IndexedCount(const Unit& u, const std::optional<std::set<int64_t>>& ids) const {
  if (!u.indexed) return 1;
  int64_t n = 0;
  for (const auto& [ch, t] : u.index)
    if (!ids || ids->count(ch)) n += int64_t(t.size());
  return std::max<int64_t>(n, 1);
}

bool McapReader::ForEach(const std::optional<std::set<int64_t>>& ids, const std::function<bool(const Sample&)>& f,
                         int64_t* damaged) const {
  // Units in order of their first log time (file order on ties), merged by log
  // time: a unit is decoded once the merge reaches its start, and while the
  // units held stay within kMergeBytes (past it, those held are given out
  // first: a file whose chunks all claim to start at 0 once made every tool
  // hold every chunk at once).
  std::vector<size_t> order;
  for (size_t i = 0; i < units_.size(); ++i)
    if (Wanted(units_[i], ids)) order.push_back(i);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return units_[a].start_ns < units_[b].start_ns; });
  struct Held {
    std::vector<uint8_t> records;
    std::vector<Msg> msgs;
    size_t left = 0;
  };
  std::map<uint32_t, Held> held;  // by position in `order`
  uint64_t held_bytes = 0;
  auto later = [](const Msg* a, const Msg* b) {
    if (a->log_ns != b->log_ns) return a->log_ns > b->log_ns;
    if (a->unit != b->unit) return a->unit > b->unit;
    return a->offset > b->offset;
  };
  std::priority_queue<Msg*, std::vector<Msg*>, decltype(later)> heap(later);
  size_t next = 0;
  Sample s;
  auto cost = [](const Held& h) { return uint64_t(h.records.capacity()) + h.msgs.capacity() * (sizeof(Msg) + 8); };
  auto load = [&](size_t k) {
    const Unit& u = units_[order[k]];
    Held h;
    std::string why;
    {
      std::lock_guard<std::mutex> lock(survey_mu_);
      if (surveys_.size() == units_.size() && surveys_[order[k]].done && !surveys_[order[k]].ok) {
        *damaged += IndexedCount(u, ids);  // known bad: not decoded again
        return;
      }
    }
    if (!Decode(u, &h.records, &h.msgs, &why)) {
      *damaged += IndexedCount(u, ids);
      return;
    }
    size_t kept = 0;
    for (const Msg& m : h.msgs) {
      if (ids && !ids->count(m.channel)) continue;
      if (!channel_ids_.count(m.channel)) {  // a message of no channel
        ++*damaged;
        continue;
      }
      h.msgs[kept] = m;
      h.msgs[kept].unit = uint32_t(order[k]);
      h.msgs[kept++].slot = uint32_t(k);
    }
    h.msgs.resize(kept);
    if (kept == 0) return;
    h.left = kept;
    auto& mine = held[uint32_t(k)] = std::move(h);
    held_bytes += cost(mine);
    for (auto& m : mine.msgs) heap.push(&m);
  };
  auto next_size = [&] {
    const Unit& u = units_[order[next]];
    return u.chunk ? u.uncompressed_size : u.records_size;
  };
  while (true) {
    while (next < order.size() && (heap.empty() || (units_[order[next]].start_ns <= heap.top()->log_ns &&
                                                    held_bytes + next_size() <= kMergeBytes)))
      load(next++);
    if (heap.empty()) break;
    Msg* m = heap.top();
    heap.pop();
    const uint32_t k = m->slot;
    Held& h = held[k];
    const uint8_t* data;
    size_t size;
    uint64_t pub_ns;
    MessageAt(h.records, m->offset, &pub_ns, &data, &size);
    s.source_ns = int64_t(pub_ns);
    s.topic_id = m->channel;
    s.arrival_ns = int64_t(m->log_ns);
    s.data.assign(data, data + size);
    if (--h.left == 0) {
      held_bytes -= cost(h);
      held.erase(k);  // m is gone from here on
    }
    if (!f(s)) return false;
  }
  return true;
}

std::optional<int64_t> McapReader::ArrivalBound(bool max, const std::optional<std::set<int64_t>>& ids) const {
  std::optional<uint64_t> out;
  auto take = [&](uint64_t t) { out = !out ? t : max ? std::max(*out, t) : std::min(*out, t); };
  for (const auto& u : units_) {
    if (u.indexed) {
      for (const auto& [ch, times] : u.index)
        if ((!ids || ids->count(ch)) && channel_ids_.count(ch))
          for (uint64_t t : times) take(t);
      continue;
    }
    const Survey& s = SurveyOf(size_t(&u - units_.data()));
    if (!s.ok) continue;
    for (const auto& [ch, c] : s.channels)
      if ((!ids || ids->count(ch)) && channel_ids_.count(ch)) take(c.min_log), take(c.max_log);
  }
  if (!out) return std::nullopt;
  return int64_t(*out);
}

std::string McapReader::QuickCheck() const {
  std::vector<std::string> all = findings_;
  for (const auto& u : units_) {
    if (int(all.size()) >= kMaxFindings) break;
    if (!u.chunk || !u.refused.empty()) continue;  // a refused unit is among the findings already (Bound)
    const Survey& s = SurveyOf(size_t(&u - units_.data()));
    if (!s.ok) all.push_back(s.why);
  }
  std::string out;
  for (const auto& f : all) out += (out.empty() ? "" : "; ") + f;
  return out;
}

std::map<int64_t, StorageReader::TopicCount> McapReader::Counts() const {
  std::map<int64_t, TopicCount> out;
  for (size_t i = 0; i < units_.size(); ++i) {
    const Survey& s = SurveyOf(i);
    if (!s.ok) continue;
    for (const auto& [ch, c] : s.channels) {
      if (!channel_ids_.count(ch)) continue;
      auto& t = out[ch];
      t.count += c.count;
      t.bytes += c.bytes;
      t.stored_bytes += c.stored;
    }
  }
  return out;
}

}  // namespace
}  // namespace mcap

std::unique_ptr<StorageReader> OpenMcapReader(const std::string& path) {
  return std::make_unique<mcap::McapReader>(path);
}

}  // namespace hullpipe::record
