// The MCAP storage's writer (mcap_format.h has the file's layout). A commit
// closes the open chunk and writes it with one write(2): a writer killed loses
// at most its open chunk; the file then lacks its summary and footer, which the
// reader does without (mcap_reader.cc).
#include <fcntl.h>
#include <unistd.h>
#include <zstd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <map>
#include <memory>

#include "hullpipe/record/storage.h"
#include "mcap_compression.h"
#include "mcap_format.h"

namespace hullpipe::record {
namespace mcap {
namespace {

class McapWriter final : public StorageWriter {
 public:
  McapWriter(const std::string& path, const WriterOptions& options);
  ~McapWriter() override;
  const std::string& path() const override { return path_; }
  int64_t AddTopic(const TopicInfo& topic) override;
  void Append(const Sample& sample) override;
  void Commit() override;
  void SetMeta(const std::string& key, const std::string& value) override;
  int64_t samples_committed() const override { return committed_; }
  int64_t samples_pending() const override { return pending_; }
  /// Chunks written, and the open chunk as it is (not yet compressed), so a split
  /// set's parts end near their size.
  int64_t stored_bytes() const override { return stored_bytes_ + int64_t(chunk_.b.size()); }
  int64_t raw_bytes() const override { return raw_bytes_; }

 private:
  void Write(const std::vector<uint8_t>& b);
  void FlushChunk();
  void WriteMetadata();
  void Close();

  struct ChunkIndex {
    uint64_t start_ns, end_ns, offset, length;
    std::map<uint16_t, uint64_t> index_offsets;
    uint64_t index_length;
    std::string compression;
    uint64_t compressed_size, uncompressed_size;
  };
  std::string path_;
  WriterOptions options_;
  int fd_ = -1;
  uint64_t offset_ = 0;  // bytes written
  ZSTD_CCtx* zstd_ = nullptr;
  // The open chunk: its records, uncompressed, and per channel (log_time, offset).
  Out chunk_;
  uint64_t chunk_start_ns_ = 0, chunk_end_ns_ = 0;
  std::map<uint16_t, std::vector<std::pair<uint64_t, uint64_t>>> index_;
  std::vector<uint8_t> compressed_;
  std::vector<ChunkIndex> chunks_;
  // Summary copies of schema and channel records.
  std::vector<std::vector<uint8_t>> schema_records_, channel_records_;
  std::map<std::string, uint16_t> schema_of_type_;
  std::vector<TopicInfo> topics_;
  std::map<uint16_t, uint32_t> sequence_;
  std::map<uint16_t, uint64_t> channel_counts_;
  uint64_t messages_ = 0, first_ns_ = 0, last_ns_ = 0;
  std::map<std::string, std::string> meta_;
  bool meta_dirty_ = false;
  struct MetadataIndex {
    uint64_t offset, length;
  };
  std::vector<MetadataIndex> metadata_;
  int64_t committed_ = 0, pending_ = 0, stored_bytes_ = 0, raw_bytes_ = 0;
  uint64_t declared_ = 0;  // chunks' uncompressed sizes so far (FileExpansionPlausible)
  bool failed_ = false;  // a write failed: the destructor writes nothing more
};

McapWriter::McapWriter(const std::string& path, const WriterOptions& options) : path_(path), options_(options) {
  options_.Check(Storage::kMcap);
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd_ < 0) {
    if (errno == EEXIST) throw RecordingError(path + ": exists; recordings are never overwritten");
    throw RecordingError(path + ": open: " + std::strerror(errno));
  }
  try {
    if (options_.compression == Compression::kZstd) {
      zstd_ = ZSTD_createCCtx();
      if (!zstd_) throw RecordingError(path_ + ": ZSTD_createCCtx failed");
      ZSTD_CCtx_setParameter(zstd_, ZSTD_c_compressionLevel, options_.zstd_level);
    }
    Out o;
    o.raw(kMagic, 8);
    const size_t h = o.Begin(kHeader);
    o.str(options_.mcap.profile);  // "" (hullpipe's), or "ros2" for a file of ROS 2 channels only
    o.str("hullpipe");
    o.End(h);
    Write(o.b);
    meta_["format"] = "mcap";
    meta_["compression"] = CompressionName(options_.compression);
    meta_dirty_ = true;
  } catch (...) {
    ZSTD_freeCCtx(zstd_);
    ::close(fd_);
    throw;
  }
}

McapWriter::~McapWriter() {
  try {
    if (!failed_) Close();
  } catch (...) {
  }
  ZSTD_freeCCtx(zstd_);
  ::close(fd_);
}

void McapWriter::Write(const std::vector<uint8_t>& b) {
  size_t done = 0;
  while (done < b.size()) {
    const ssize_t n = ::write(fd_, b.data() + done, b.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      failed_ = true;
      throw RecordingError(path_ + ": write: " + (n < 0 ? std::strerror(errno) : "no space written"));
    }
    done += size_t(n);
  }
  offset_ += b.size();
}

int64_t McapWriter::AddTopic(const TopicInfo& t) {
  for (const auto& mine : topics_)
    if (mine.name == t.name) return mine.id;
  if (topics_.size() >= 65535) throw RecordingError(path_ + ": more than 65535 topics (MCAP channel ids are 16-bit)");
  Out o;
  auto s = schema_of_type_.find(t.type);
  if (s == schema_of_type_.end()) {
    const uint16_t id = uint16_t(schema_of_type_.size() + 1);
    Out rec;
    const size_t at = rec.Begin(kSchema);
    rec.u16(id);
    rec.str(t.type);
    // The IDL text, self-contained (idl/hullpipe.idl has no preprocessor
    // directives); where a recording has none, no schema encoding (the spec's
    // "no schema available"), the type still named.
    rec.str(!t.schema_encoding.empty() ? t.schema_encoding : t.type_description.empty() ? "" : "omgidl");
    rec.str(t.type_description);
    rec.End(at);
    schema_records_.push_back(rec.b);
    o.raw(rec.b.data(), rec.b.size());
    s = schema_of_type_.emplace(t.type, id).first;
  }
  TopicInfo mine = t;
  mine.id = int64_t(topics_.size() + 1);
  Out rec;
  const size_t at = rec.Begin(kChannel);
  rec.u16(uint16_t(mine.id));
  rec.u16(s->second);
  rec.str(t.name);
  rec.str(t.message_encoding);
  if (!t.offered_qos_profiles.empty()) rec.map({{"offered_qos_profiles", t.offered_qos_profiles}});
  else if (t.message_encoding == "cdr") rec.map({{"qos", QosYaml(t)}});
  else rec.map({});
  rec.End(at);
  channel_records_.push_back(rec.b);
  o.raw(rec.b.data(), rec.b.size());
  Write(o.b);
  topics_.push_back(mine);
  return mine.id;
}

void McapWriter::Append(const Sample& s) {
  if (s.topic_id < 1 || s.topic_id > int64_t(topics_.size()))
    throw RecordingError(path_ + ": a sample of topic id " + std::to_string(s.topic_id) + ", which was never added");
  const uint16_t ch = uint16_t(s.topic_id);
  const uint64_t log_ns = uint64_t(s.arrival_ns), pub_ns = uint64_t(s.source_ns);
  const uint64_t record = 9 + 22 + s.data.size();
  if (record > kMaxChunkBytes)
    throw RecordingError(path_ + ": a sample of " + std::to_string(s.data.size()) + " bytes on topic '" +
                         topics_[size_t(s.topic_id - 1)].name + "', over the MCAP storage's " +
                         std::to_string(kMaxChunkBytes >> 20) + " MiB a chunk");
  if (chunk_.b.size() + record > kMaxChunkBytes) FlushChunk();
  if (chunk_.b.empty() || log_ns < chunk_start_ns_) chunk_start_ns_ = log_ns;
  if (chunk_.b.empty() || log_ns > chunk_end_ns_) chunk_end_ns_ = log_ns;
  index_[ch].emplace_back(log_ns, uint64_t(chunk_.b.size()));
  const size_t at = chunk_.Begin(kMessage);
  chunk_.u16(ch);
  chunk_.u32(++sequence_[ch]);
  chunk_.u64(log_ns);
  chunk_.u64(pub_ns);
  chunk_.raw(s.data.data(), s.data.size());
  chunk_.End(at);
  if (messages_ == 0 || log_ns < first_ns_) first_ns_ = log_ns;
  if (messages_ == 0 || log_ns > last_ns_) last_ns_ = log_ns;
  ++messages_;
  ++channel_counts_[ch];
  ++pending_;
  raw_bytes_ += int64_t(s.data.size());
  if (int64_t(chunk_.b.size()) >= options_.mcap.chunk_bytes) FlushChunk();
}

void McapWriter::FlushChunk() {
  if (chunk_.b.empty()) return;
  const std::vector<uint8_t>& records = chunk_.b;
  const uint32_t crc = Crc(0, records.data(), records.size());
  // Compressed only while the file's chunks stay within what its size allows
  // (FileExpansionPlausible; the chunk's own header and indexes only add bytes).
  const bool compressed =
      Compress(options_.compression, zstd_, records, &compressed_, path_) &&
      FileExpansionPlausible(declared_ + records.size(), offset_ + compressed_.size());
  declared_ += records.size();
  const std::vector<uint8_t>& stored = compressed ? compressed_ : records;
  const std::string compression = compressed ? CompressionName(options_.compression) : "";
  Out o;
  const size_t at = o.Begin(kChunk);
  o.u64(chunk_start_ns_);
  o.u64(chunk_end_ns_);
  o.u64(records.size());
  o.u32(crc);
  o.str(compression);
  o.u64(stored.size());
  o.raw(stored.data(), stored.size());
  o.End(at);
  ChunkIndex ci{chunk_start_ns_, chunk_end_ns_, offset_, o.b.size(), {}, 0, compression, stored.size(), records.size()};
  for (const auto& [ch, entries] : index_) {
    ci.index_offsets[ch] = offset_ + o.b.size();
    const size_t m = o.Begin(kMessageIndex);
    o.u16(ch);
    o.u32(uint32_t(entries.size() * 16));
    for (const auto& [t, off] : entries) {
      o.u64(t);
      o.u64(off);
    }
    o.End(m);
  }
  ci.index_length = offset_ + o.b.size() - ci.offset - ci.length;
  Write(o.b);  // the chunk and its indexes in one write(2)
  chunks_.push_back(std::move(ci));
  stored_bytes_ += int64_t(stored.size());
  committed_ += pending_;
  pending_ = 0;
  chunk_.b.clear();
  index_.clear();
}

void McapWriter::WriteMetadata() {
  Out o;
  const size_t at = o.Begin(kMetadata);
  o.str(kMetaName);
  o.map(meta_);
  o.End(at);
  metadata_.push_back({offset_, o.b.size()});
  Write(o.b);
  meta_dirty_ = false;
}

void McapWriter::Commit() {
  FlushChunk();
  if (meta_dirty_) WriteMetadata();
}

void McapWriter::SetMeta(const std::string& key, const std::string& value) {
  auto it = meta_.find(key);
  if (it != meta_.end() && it->second == value) return;
  meta_[key] = value;
  meta_dirty_ = true;
}

void McapWriter::Close() {
  SetMeta("closed_ns", std::to_string(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                          std::chrono::system_clock::now().time_since_epoch())
                                          .count()));
  Commit();
  Out o;
  size_t at = o.Begin(kDataEnd);
  o.u32(0);  // no data-section CRC: every chunk carries its own
  o.End(at);
  const uint64_t summary_start = offset_ + o.b.size();
  struct Group {
    uint8_t op;
    uint64_t start, length;
  };
  std::vector<Group> groups;
  auto group = [&](uint8_t op, const std::function<void()>& write) {
    const uint64_t start = offset_ + o.b.size();
    write();
    const uint64_t length = offset_ + o.b.size() - start;
    if (length > 0) groups.push_back({op, start, length});
  };
  group(kSchema, [&] {
    for (const auto& r : schema_records_) o.raw(r.data(), r.size());
  });
  group(kChannel, [&] {
    for (const auto& r : channel_records_) o.raw(r.data(), r.size());
  });
  group(kStatistics, [&] {
    const size_t s = o.Begin(kStatistics);
    o.u64(messages_);
    o.u16(uint16_t(schema_records_.size()));
    o.u32(uint32_t(channel_records_.size()));
    o.u32(0);  // attachments
    o.u32(uint32_t(metadata_.size()));
    o.u32(uint32_t(chunks_.size()));
    o.u64(messages_ ? first_ns_ : 0);
    o.u64(messages_ ? last_ns_ : 0);
    const size_t m = o.b.size();
    o.u32(0);
    for (const auto& [ch, n] : channel_counts_) {
      o.u16(ch);
      o.u64(n);
    }
    o.patch(m, o.b.size() - m - 4, 4);
    o.End(s);
  });
  group(kMetadataIndex, [&] {
    for (const auto& m : metadata_) {
      const size_t s = o.Begin(kMetadataIndex);
      o.u64(m.offset);
      o.u64(m.length);
      o.str(kMetaName);
      o.End(s);
    }
  });
  group(kChunkIndex, [&] {
    for (const auto& c : chunks_) {
      const size_t s = o.Begin(kChunkIndex);
      o.u64(c.start_ns);
      o.u64(c.end_ns);
      o.u64(c.offset);
      o.u64(c.length);
      const size_t m = o.b.size();
      o.u32(0);
      for (const auto& [ch, off] : c.index_offsets) {
        o.u16(ch);
        o.u64(off);
      }
      o.patch(m, o.b.size() - m - 4, 4);
      o.u64(c.index_length);
      o.str(c.compression);
      o.u64(c.compressed_size);
      o.u64(c.uncompressed_size);
      o.End(s);
    }
  });
  const uint64_t summary_offset_start = offset_ + o.b.size();
  for (const auto& g : groups) {
    const size_t s = o.Begin(kSummaryOffset);
    o.u8(g.op);
    o.u64(g.start);
    o.u64(g.length);
    o.End(s);
  }
  const size_t summary_at = size_t(summary_start - offset_);
  o.u8(kFooter);
  o.u64(20);  // fixed length: it is in the CRC below
  o.u64(summary_start);
  o.u64(summary_offset_start);
  // The summary's CRC: from its start through the footer's summary_offset_start.
  o.u32(Crc(0, o.b.data() + summary_at, o.b.size() - summary_at));
  o.raw(kMagic, 8);
  Write(o.b);
}

}  // namespace
}  // namespace mcap

std::unique_ptr<StorageWriter> OpenMcapWriter(const std::string& path, const WriterOptions& options) {
  return std::make_unique<mcap::McapWriter>(path, options);
}

}  // namespace hullpipe::record
