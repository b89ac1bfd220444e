// The MCAP storage's file format (https://mcap.dev/spec, major version 0;
// docs/recording.md "MCAP"), shared by its writer (mcap_writer.cc) and reader
// (mcap_reader.cc). Internal to the recording library. What hullpipe writes:
//   <Magic><Header profile "" library "hullpipe">
//   data section: Schema and Channel records (top level, as each topic is added),
//     Chunks of Message records, each followed by one Message Index per channel,
//     Metadata records named "hullpipe" (the recording's meta, written again
//     whenever it changed, at a commit), <Data End crc 0>
//   summary section (at close): Schemas, Channels, Statistics, Metadata Indexes,
//     Chunk Indexes, grouped by opcode, then one Summary Offset per group,
//   <Footer with the summary's CRC-32><Magic>.
// A topic is a channel (id = topic id) with message encoding "cdr" and a schema
// named by the type ("hullpipe::msg::CameraInfo"), encoding "omgidl", its data
// the IDL text; the QoS is channel metadata 'qos', YAML in the keys eProsima's
// DDS recorder uses (reliability, durability, ownership, keyed; booleans) plus
// depth. log_time is the arrival time, publish_time the source time.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "hullpipe/record/recording.h"

namespace hullpipe::record::mcap {


constexpr uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
enum Op : uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};
constexpr const char* kMetaName = "hullpipe";
// A chunk's (or a loose message record's) declared uncompressed size above this
// is damage, not an allocation: the writer closes a chunk at --chunk-size
// (<= 128 MiB) and before a sample that would take it past this bound, and
// refuses a sample over it. With the merge bound below, every tool reads any
// file within 1 GiB (docs/recording.md, "Bounds"): one chunk, its messages'
// places (24 bytes each), and the sample given.
constexpr uint64_t kMaxChunkBytes = uint64_t(256) << 20;
// What a file's chunks may declare uncompressed, all together: 1024 times the
// file's bytes plus 64 MiB (ZstdRatioPlausible, for the whole file). A 106-KB
// file of 40 zstd chunks of 64 MiB of zeros (each under the per-chunk rule)
// made every tool decompress 2.5 GiB; the chunks past the bound are refused as
// damaged, unread. The writer keeps it (a chunk that would break it is stored
// as it is).
constexpr bool FileExpansionPlausible(uint64_t declared, uint64_t file_bytes) {
  return declared <= uint64_t(kMaxZstdRatio) * file_bytes + uint64_t(kRatioFreeBytes);
}

/// CRC-32 (zlib's, as the spec's) of n bytes at p, continuing `crc` (0 to start).
uint32_t Crc(uint32_t crc, const uint8_t* p, size_t n);

struct Out {
  std::vector<uint8_t> b;
  void le(uint64_t v, int n) {
    for (int i = 0; i < n; ++i) b.push_back(uint8_t(v >> (8 * i)));
  }
  void u8(uint8_t v) { b.push_back(v); }
  void u16(uint16_t v) { le(v, 2); }
  void u32(uint32_t v) { le(v, 4); }
  void u64(uint64_t v) { le(v, 8); }
  void raw(const uint8_t* p, size_t n) { b.insert(b.end(), p, p + n); }
  void str(const std::string& s) {
    u32(uint32_t(s.size()));
    b.insert(b.end(), s.begin(), s.end());
  }
  void patch(size_t at, uint64_t v, int n) {
    for (int i = 0; i < n; ++i) b[at + i] = uint8_t(v >> (8 * i));
  }
  size_t Begin(uint8_t op) {  // opcode and a length patched by End
    u8(op);
    u64(0);
    return b.size();
  }
  void End(size_t content_at) { patch(content_at - 8, b.size() - content_at, 8); }
  void map(const std::map<std::string, std::string>& m) {
    const size_t at = b.size();
    u32(0);
    for (const auto& [k, v] : m) {
      str(k);
      str(v);
    }
    patch(at, b.size() - at - 4, 4);
  }
};

// What the reader throws at a field that runs past its record: caught and named
// with the file and the record's offset.
struct Malformed : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct In {
  const uint8_t* p;
  size_t n;
  size_t at = 0;
  void need(size_t k, const char* field) const {
    if (n - at < k) throw Malformed(std::string("its ") + field + " runs past the record's end");
  }
  uint64_t le(int k, const char* field) {
    need(size_t(k), field);
    uint64_t v = 0;
    for (int i = 0; i < k; ++i) v |= uint64_t(p[at + i]) << (8 * i);
    at += size_t(k);
    return v;
  }
  uint8_t u8(const char* f) { return uint8_t(le(1, f)); }
  uint16_t u16(const char* f) { return uint16_t(le(2, f)); }
  uint32_t u32(const char* f) { return uint32_t(le(4, f)); }
  uint64_t u64(const char* f) { return le(8, f); }
  std::string str(const char* f) {
    const uint32_t len = u32(f);
    need(len, f);
    std::string s(reinterpret_cast<const char*>(p + at), len);
    at += len;
    return s;
  }
  In sub(uint64_t len, const char* f) {  // a length-prefixed part
    need(size_t(std::min<uint64_t>(len, SIZE_MAX)), f);
    In s{p + at, size_t(len)};
    at += size_t(len);
    return s;
  }
  std::map<std::string, std::string> map(const char* f) {
    In m = sub(u32(f), f);
    std::map<std::string, std::string> out;
    while (m.at < m.n) {
      std::string k = m.str(f);
      out[k] = m.str(f);
    }
    return out;
  }
  bool done() const { return at >= n; }
};

/// A topic's QoS as the channel metadata 'qos' holds it: YAML in the keys
/// eProsima's DDS recorder uses (reliability, durability, ownership, keyed;
/// booleans) plus depth, with a final newline.
std::string QosYaml(const TopicInfo& t);

}  // namespace hullpipe::record::mcap
