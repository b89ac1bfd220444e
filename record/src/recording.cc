#include "hullpipe/record/recording.h"

#include <fnmatch.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>

#include "hullpipe/record/storage.h"

namespace hullpipe::record {

// CRC-32 (zlib) of a sample's row: topic id, source and arrival times (8 bytes
// each, little-endian) and the data, so a flip in any of them is found.
uint32_t RowCrc(int64_t topic_id, int64_t source_ns, int64_t arrival_ns, const uint8_t* data, size_t size) {
  uLong c = crc32(0L, Z_NULL, 0);
  for (int64_t v : {topic_id, source_ns, arrival_ns}) {
    uint8_t le[8];
    for (int i = 0; i < 8; ++i) le[i] = uint8_t(uint64_t(v) >> (8 * i));
    c = crc32(c, le, 8);
  }
  size_t off = 0;
  while (off < size) {  // zlib takes uInt lengths
    const size_t n = std::min<size_t>(size - off, 1u << 30);
    c = crc32(c, data + off, uInt(n));
    off += n;
  }
  return uint32_t(c);
}

const char* CompressionName(Compression c) {
  return c == Compression::kZstd ? "zstd" : c == Compression::kLz4 ? "lz4" : "none";
}

Compression ParseCompression(const std::string& name) {
  if (name == "none") return Compression::kNone;
  if (name == "zstd") return Compression::kZstd;
  if (name == "lz4") return Compression::kLz4;
  throw std::invalid_argument("--compression must be none, zstd or lz4, not '" + name + "'");
}

const char* StorageName(Storage s) { return StorageKindOf(s).name; }

Storage ParseStorage(const std::string& name) {
  std::string names;
  for (const StorageKind& k : Storages()) {
    if (name == k.name) return k.id;
    names += (names.empty() ? "" : " or ") + std::string(k.name);
  }
  throw std::invalid_argument("--storage must be " + names + ", not '" + name + "'");
}

Storage StorageForPath(const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  for (const StorageKind& k : Storages())
    if (ext == k.extension) return k.id;
  return Storages().front().id;
}

const char* StorageExtension(Storage s) { return StorageKindOf(s).extension; }

void WriterOptions::Check() const {
  if (zstd_level < 1 || zstd_level > 19) throw std::invalid_argument("--zstd-level must be in [1, 19]");
  if (mcap.chunk_bytes < 1024 || mcap.chunk_bytes > (int64_t(128) << 20))
    throw std::invalid_argument("--chunk-size must be in [1 KiB, 128 MiB]");
  if (mcap.profile != "" && mcap.profile != "ros2") throw std::invalid_argument("an MCAP profile is \"\" or ros2");
  if (storage) Check(*storage);
}

void WriterOptions::Check(Storage s) const {
  const StorageKind& k = StorageKindOf(s);
  if (std::find(k.compressions.begin(), k.compressions.end(), compression) != k.compressions.end()) return;
  std::string takes, others;
  for (Compression c : k.compressions) takes += (takes.empty() ? "" : ", ") + std::string(CompressionName(c));
  for (const StorageKind& o : Storages())
    if (std::find(o.compressions.begin(), o.compressions.end(), compression) != o.compressions.end())
      others += std::string(others.empty() ? "" : ", ") + "-o FILE" + o.extension + " or --storage " + o.name;
  throw std::invalid_argument(
      std::string("--compression ") + CompressionName(compression) + " is not for " + k.name +
      " recordings (they take " + takes + ")" +
      (others.empty() ? "" : std::string("; for ") + CompressionName(compression) + ": " + others));
}

bool DecodeSampleData(const uint8_t* data, size_t n, int codec, int64_t size, std::vector<uint8_t>* out) {
  if (codec == 0) {
    out->assign(data, data + n);
    return true;
  }
  if (codec != 1 || size < 0 || size > kMaxSampleBytes || !ZstdRatioPlausible(n, size)) return false;
  const unsigned long long declared = ZSTD_getFrameContentSize(data, n);
  if (declared != (unsigned long long)size) return false;
  // Streamed into a buffer that doubles (from 4x the input): the allocation
  // follows the output.
  std::unique_ptr<ZSTD_DCtx, size_t (*)(ZSTD_DCtx*)> d(ZSTD_createDCtx(), ZSTD_freeDCtx);
  if (!d) return false;
  out->clear();
  ZSTD_inBuffer in{data, n, 0};
  size_t have = 0;
  while (true) {
    if (have == out->size()) {
      if (out->size() == size_t(size)) {  // full: the frame must end here
        uint8_t probe;
        ZSTD_outBuffer o{&probe, 1, 0};
        const size_t r = ZSTD_decompressStream(d.get(), &o, &in);
        return !ZSTD_isError(r) && o.pos == 0 && r == 0 && in.pos == in.size;
      }
      out->resize(
          size_t(std::min<uint64_t>(uint64_t(size), std::max<uint64_t>(2 * out->size(), uint64_t(n) * 4 + 65536))));
    }
    ZSTD_outBuffer o{out->data(), out->size(), have};
    const size_t r = ZSTD_decompressStream(d.get(), &o, &in);
    if (ZSTD_isError(r)) return false;
    have = o.pos;
    if (r == 0) return have == size_t(size) && in.pos == in.size;
    if (in.pos == in.size && o.pos < o.size) return false;  // the input ended, the frame did not
  }
}

bool IsMcapFile(const std::string& path) {
  static const char kMagic[8] = {char(0x89), 'M', 'C', 'A', 'P', '0', '\r', '\n'};
  std::ifstream in(path, std::ios::binary);
  char head[8] = {};
  return in.read(head, 8) && std::memcmp(head, kMagic, 8) == 0;
}

std::unique_ptr<StorageReader> OpenStorageReader(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw RecordingError(path + ": no such recording (not a file)");
  if (std::filesystem::file_size(path, ec) == 0) throw RecordingError(path + ": empty file, not a hullpipe recording");
  return StorageKindOfFile(path).open_reader(path);
}

void StorageWriter::AppendEncoded(const EncodedSample& e) {
  Sample s;
  s.topic_id = e.topic_id;
  s.source_ns = e.source_ns;
  s.arrival_ns = e.arrival_ns;
  if (!DecodeSampleData(e.data.data(), e.data.size(), e.codec, e.size, &s.data))
    throw RecordingError(path() + ": a sample given encoded with codec " + std::to_string(e.codec) +
                         " does not decode");
  Append(s);
}

RecordingWriter::RecordingWriter(const std::string& path, const WriterOptions& options)
    : path_(path), storage_(options.storage.value_or(StorageForPath(path))) {
  options.Check();
  options.Check(storage_);
  impl_ = StorageKindOf(storage_).open_writer(path, options);
}

RecordingWriter::~RecordingWriter() = default;

int64_t RecordingWriter::AddTopic(const TopicInfo& topic) { return impl_->AddTopic(topic); }
void RecordingWriter::Append(const Sample& sample) { impl_->Append(sample); }
void RecordingWriter::Commit() { impl_->Commit(); }
void RecordingWriter::SetMeta(const std::string& key, const std::string& value) { impl_->SetMeta(key, value); }
int64_t RecordingWriter::samples_committed() const { return impl_->samples_committed(); }
int64_t RecordingWriter::samples_pending() const { return impl_->samples_pending(); }
int64_t RecordingWriter::stored_bytes() const { return impl_->stored_bytes(); }
int64_t RecordingWriter::raw_bytes() const { return impl_->raw_bytes(); }

void RecordingWriter::AppendEncoded(const EncodedSample& sample) { impl_->AppendEncoded(sample); }

// One file of a recording.
struct RecordingReader::Part {
  std::unique_ptr<StorageReader> r;
  std::map<int64_t, int64_t> to_set_id;    // file topic id -> reader's topic id
  // The file ids of the reader's topics `ids` (nullopt: all).
  std::optional<std::set<int64_t>> FileIds(const std::optional<std::vector<int64_t>>& ids) const {
    if (!ids) return std::nullopt;
    std::set<int64_t> out;
    for (const auto& [file_id, set_id] : to_set_id)
      if (std::find(ids->begin(), ids->end(), set_id) != ids->end()) out.insert(file_id);
    return out;
  }
};

RecordingReader::RecordingReader(const std::string& path) : path_(path) {
  std::error_code ec;
  std::vector<std::string> files;
  if (std::filesystem::is_directory(path, ec)) {
    for (const auto& e : std::filesystem::directory_iterator(path, ec)) {
      const auto ext = e.path().extension();
      if ((ext == ".hprec" || ext == ".mcap") && e.is_regular_file(ec)) files.push_back(e.path().string());
    }
    if (files.empty())
      throw RecordingError(path + ": a directory without .hprec or .mcap files, not a hullpipe recording");
    std::sort(files.begin(), files.end());
  } else {
    files.push_back(path);
  }
  for (const auto& f : files) {
    auto part = std::make_unique<Part>();
    part->r = OpenStorageReader(f);
    parts_.push_back(std::move(part));
  }
  if (parts_.size() > 1) {
    // One split recording: one set id, parts numbered without repeats, in order.
    std::map<int64_t, std::unique_ptr<Part>> by_index;
    std::set<std::string> sets;
    for (auto& p : parts_) {
      const auto& meta = p->r->meta();
      sets.insert(meta.count("set") ? meta.at("set") : "(none: " + p->r->path() + ")");
      int64_t index = -1;
      try {
        index = std::stoll(meta.count("part") ? meta.at("part") : "-1");
      } catch (const std::exception&) {
      }
      if (index < 0)
        throw RecordingError(p->r->path() + ": no meta 'part'; " + path + " holds files of several recordings");
      if (by_index.count(index))
        throw RecordingError(path + ": two files of part " + std::to_string(index) + " (" +
                             by_index[index]->r->path() + ", " + p->r->path() + ")");
      by_index[index] = std::move(p);
    }
    if (sets.size() > 1)
      throw RecordingError(path + ": holds files of " + std::to_string(sets.size()) +
                           " recordings (meta 'set'); give one file");
    parts_.clear();
    int64_t expect = 0;
    for (auto& [index, p] : by_index) {
      for (; expect < index; ++expect)
        missing_parts_ += (missing_parts_.empty() ? "" : ", ") + ("part " + std::to_string(expect) + " missing");
      ++expect;
      parts_.push_back(std::move(p));
    }
  }
  // The reader's topics: each name once, with the id of the part it first
  // appears in unless another name took that id.
  std::set<int64_t> used;
  std::map<std::string, int64_t> by_name;
  for (auto& p : parts_) {
    for (const auto& t : p->r->topics()) {
      auto it = by_name.find(t.name);
      if (it == by_name.end()) {
        TopicInfo mine = t;
        if (used.count(mine.id)) mine.id = *used.rbegin() + 1;
        used.insert(mine.id);
        it = by_name.emplace(t.name, mine.id).first;
        topics_.push_back(mine);
      }
      p->to_set_id[t.id] = it->second;
    }
  }
}

RecordingReader::~RecordingReader() = default;

std::vector<std::string> RecordingReader::files() const {
  std::vector<std::string> out;
  for (const auto& p : parts_) out.push_back(p->r->path());
  return out;
}

void RecordingReader::ForEach(const std::function<bool(const Sample&)>& f,
                              const std::optional<std::vector<int64_t>>& topic_ids) const {
  Sample mapped;
  for (const auto& p : parts_) {
    const auto ids = p->FileIds(topic_ids);
    if (ids && ids->empty()) continue;
    const bool more = p->r->ForEach(
        ids,
        [&](const Sample& s) {
          // Storages yield only samples of their own topics: every id maps.
          const auto it = p->to_set_id.find(s.topic_id);
          if (it == p->to_set_id.end() || it->second == s.topic_id) return f(s);
          mapped.topic_id = it->second;
          mapped.source_ns = s.source_ns;
          mapped.arrival_ns = s.arrival_ns;
          mapped.data = s.data;
          return f(mapped);
        },
        &damaged_);
    if (!more) return;
  }
}

std::optional<int64_t> RecordingReader::ArrivalBound(const char* fn,
                                                     const std::optional<std::vector<int64_t>>& topic_ids) const {
  std::optional<int64_t> out;
  const bool max = std::string(fn) == "MAX";
  for (const auto& p : parts_) {
    const auto ids = p->FileIds(topic_ids);
    if (ids && ids->empty()) continue;
    const auto v = p->r->ArrivalBound(max, ids);
    if (!v) continue;
    out = !out ? *v : max ? std::max(*out, *v) : std::min(*out, *v);
  }
  return out;
}

std::optional<int64_t> RecordingReader::FirstArrivalNs(const std::optional<std::vector<int64_t>>& topic_ids) const {
  return ArrivalBound("MIN", topic_ids);
}

std::optional<int64_t> RecordingReader::LastArrivalNs(const std::optional<std::vector<int64_t>>& topic_ids) const {
  return ArrivalBound("MAX", topic_ids);
}

std::string RecordingReader::QuickCheck() const {
  std::string out;
  for (const auto& p : parts_) {
    std::string mine;
    try {
      mine = p->r->QuickCheck();
    } catch (const RecordingError& e) {
      mine = e.what();
    }
    if (!mine.empty()) out += (out.empty() ? "" : "; ") + (parts_.size() > 1 ? p->r->path() + ": " : "") + mine;
  }
  return out;
}

RecordingInfo RecordingReader::Info() const {
  RecordingInfo info;
  info.damage = QuickCheck();
  if (!missing_parts_.empty()) info.damage += (info.damage.empty() ? "" : "; ") + missing_parts_;
  try {
    Counts(&info);
  } catch (const RecordingError& e) {  // a damaged file: the counts so far
    info.damage += (info.damage.empty() ? "" : "; ") + std::string(e.what());
  }
  info.interrupted = parts_.back()->r->interrupted();
  // Every sample's CRC (and samples of no known topic): from the storages where
  // they know it (an MCAP file's chunks were each decoded once above), else by
  // reading every sample.
  std::optional<int64_t> known = 0;
  for (const auto& p : parts_) {
    const auto d = p->r->DamagedSamples();
    known = d && known ? std::optional<int64_t>(*known + *d) : std::nullopt;
  }
  if (known) {
    info.damaged_samples = *known;
  } else {
    const int64_t before = damaged_;
    try {
      ForEach([](const Sample&) { return true; });
    } catch (const RecordingError& e) {
      info.damage += (info.damage.empty() ? "" : "; ") + std::string(e.what());
    }
    info.damaged_samples = damaged_ - before;
  }
  if (info.damaged_samples > 0)
    info.damage +=
        (info.damage.empty() ? "" : "; ") + std::to_string(info.damaged_samples) +
        " sample(s) whose row does not match its CRC-32, whose data does not decode, or whose topic is unknown";
  return info;
}

void RecordingReader::Counts(RecordingInfo* out) const {
  RecordingInfo& info = *out;
  std::map<int64_t, size_t> row;  // reader topic id -> index in info.topics
  for (const auto& t : topics_) {
    row[t.id] = info.topics.size();
    info.topics.push_back({t});
  }
  std::set<std::string> compressions;
  info.format = parts_.front()->r->format();
  info.storage = StorageName(parts_.front()->r->storage());
  for (const auto& p : parts_) {
    info.files.push_back(p->r->path());
    info.file_bytes += p->r->FileBytes();
    for (const auto& [k, v] : p->r->meta()) info.meta[k] = v;
    const auto& meta = p->r->meta();
    compressions.insert(meta.count("compression") ? meta.at("compression") : "none");
  }
  for (const auto& c : compressions) info.compression += (info.compression.empty() ? "" : ", ") + c;
  for (const auto& p : parts_) {
    for (const auto& [file_id, c] : p->r->Counts()) {
      const auto id = p->to_set_id.find(file_id);
      if (id == p->to_set_id.end()) continue;  // rows of no topic: counted as damage by ForEach
      auto& ts = info.topics[row.at(id->second)];
      ts.count += c.count;
      ts.bytes += c.bytes;
      ts.stored_bytes += c.stored_bytes;
    }
  }
  for (auto& ts : info.topics) {
    info.samples += ts.count;
    info.bytes += ts.bytes;
    info.stored_bytes += ts.stored_bytes;
    const auto lost = info.meta.find("lost:" + ts.topic.name);
    if (lost != info.meta.end()) {
      try {
        ts.lost = std::stoll(lost->second);
      } catch (const std::exception&) {
      }
    }
  }
  info.first_arrival_ns = FirstArrivalNs().value_or(0);
  info.last_arrival_ns = LastArrivalNs().value_or(0);
}

bool TopicMatches(const std::string& pattern, const std::string& name) {
  return fnmatch(pattern.c_str(), name.c_str(), 0) == 0;
}

bool TopicSelected(const std::vector<std::string>& include, const std::vector<std::string>& exclude,
                   const std::string& name) {
  bool in = include.empty();
  for (const auto& p : include) in = in || TopicMatches(p, name);
  for (const auto& p : exclude)
    if (TopicMatches(p, name)) return false;
  return in;
}

}  // namespace hullpipe::record
