// The MCAP storage (docs/recording.md "MCAP", https://mcap.dev/spec), the library
// alone: round trips in every compression, the record layout the spec asks for,
// arrival order across chunks, split sets, conversion to and from SQLite byte for
// byte, files cut at any byte and a killed writer repaired to their intact
// chunks, and files that lie (CRC, sizes, lengths, schema ids) named in one line.
// Independent readers (@mcap/core, Foxglove's OMG IDL decoder) judge the files in
// record_mcap_interop_test (tests/js).
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>

#include <gtest/gtest.h>
#include <zlib.h>
#include <zstd.h>

#include "hullpipe/util/sanitized.h"
#include "hullpipe/record/convert.h"
#include "hullpipe/record/player.h"
#include "hullpipe/record/recording.h"
#include "hullpipe/record/repair.h"
#include "hullpipe/record/split_writer.h"
#include "record_fixtures.h"
#include "test_util.h"

namespace hullpipe {
namespace {

using namespace hullpipe::record;
using test::ExpectSame;
using test::kInfoTopic;
using test::kMapTopic;
using test::kPoseTopic;
using test::ReadAll;
using test::StreamSample;

// A CameraInfo, then n - 1 samples alternating maps and head poses, committed
// every `commit_every`, in chunks of `chunk_bytes`.
std::vector<Sample> WriteMcapStream(const std::string& path, Compression c, int n, int commit_every,
                                    int64_t chunk_bytes = int64_t(4) << 20) {
  WriterOptions o;
  o.compression = c;
  o.mcap.chunk_bytes = chunk_bytes;
  RecordingWriter w(path, o);
  EXPECT_EQ(w.storage(), Storage::kMcap);
  const int64_t info = w.AddTopic(kInfoTopic), map = w.AddTopic(kMapTopic), pose = w.AddTopic(kPoseTopic);
  EXPECT_EQ(w.AddTopic(kMapTopic), map);  // the same name: the same id
  std::vector<Sample> written{StreamSample(info, 0)};
  for (int k = 1; k < n; ++k) written.push_back(StreamSample(k % 3 ? map : pose, k));
  for (size_t k = 0; k < written.size(); ++k) {
    w.Append(written[k]);
    if (int(k) % commit_every == commit_every - 1) w.Commit();
  }
  w.SetMeta("domain", "7");
  return written;
}


uint64_t Le(const std::string& b, size_t at, int n) {
  uint64_t v = 0;
  for (int i = 0; i < n; ++i) v |= uint64_t(uint8_t(b[at + size_t(i)])) << (8 * i);
  return v;
}

// The top-level records of an MCAP file: (offset, opcode, content length).
struct Record {
  size_t at;
  uint8_t op;
  uint64_t len;
};
std::vector<Record> TopLevel(const std::string& b) {
  std::vector<Record> out;
  size_t at = 8;
  while (at + 9 <= b.size() - 8) {
    const Record r{at, uint8_t(b[at]), Le(b, at + 1, 8)};
    out.push_back(r);
    if (r.op == 0x02) break;
    at += 9 + size_t(r.len);
  }
  return out;
}

// Every compression round-trips byte for byte, in arrival order, with the
// topics' types, IDL texts and QoS; info names the storage and compression.
TEST(McapStorage, EveryCompressionRoundTripsByteForByte) {
  const auto dir = test::TempDir("mcap_roundtrip");
  for (const Compression c : {Compression::kNone, Compression::kZstd, Compression::kLz4}) {
    const std::string path = (dir / (std::string(CompressionName(c)) + ".mcap")).string();
    // 64 KiB chunks: ~50 chunks, so indexes, merges and sizes are exercised.
    const auto written = WriteMcapStream(path, c, 300, 25, 64 << 10);
    const RecordingReader r(path);
    ExpectSame(ReadAll(r), written);
    ASSERT_EQ(r.topics().size(), 3u);
    for (size_t i = 0; i < 3; ++i) {
      const TopicInfo& want = i == 0 ? kInfoTopic : i == 1 ? kMapTopic : kPoseTopic;
      const TopicInfo& got = r.topics()[i];
      EXPECT_EQ(got.id, int64_t(i + 1));
      EXPECT_EQ(got.name, want.name);
      EXPECT_EQ(got.type, want.type);
      EXPECT_EQ(got.type_description, want.type_description);
      EXPECT_EQ(got.keyed, want.keyed) << want.name;
      EXPECT_EQ(got.reliable, want.reliable) << want.name;
      EXPECT_EQ(got.transient_local, want.transient_local) << want.name;
      EXPECT_EQ(got.depth, want.depth) << want.name;
    }
    const RecordingInfo info = r.Info();
    EXPECT_EQ(info.damage, "");
    EXPECT_EQ(info.storage, "mcap");
    EXPECT_EQ(info.format, "mcap");
    EXPECT_EQ(info.compression, c == Compression::kNone ? "none" : CompressionName(c));
    EXPECT_FALSE(info.interrupted);
    EXPECT_EQ(info.samples, 300);
    EXPECT_EQ(info.meta.at("domain"), "7");
    int64_t bytes = 0;
    for (const auto& s : written) bytes += int64_t(s.data.size());
    EXPECT_EQ(info.bytes, bytes);
    if (c != Compression::kNone) {
      EXPECT_LT(info.stored_bytes, bytes * 7 / 10) << CompressionName(c);
    }
    EXPECT_EQ(info.topics[1].count, 200);  // k = 1..299 with k % 3 != 0
    // One topic alone, and its first and last arrival from the message indexes.
    const auto poses = ReadAll(r, std::vector<int64_t>{3});
    ASSERT_EQ(poses.size(), 99u);
    EXPECT_EQ(poses.front().arrival_ns, StreamSample(3, 3).arrival_ns);
    EXPECT_EQ(r.FirstArrivalNs(std::vector<int64_t>{3}).value(), StreamSample(3, 3).arrival_ns);
    EXPECT_EQ(r.LastArrivalNs(std::vector<int64_t>{3}).value(), StreamSample(3, 297).arrival_ns);
    EXPECT_EQ(r.LastArrivalNs().value(), written.back().arrival_ns);
  }
  WriterOptions lz4;
  lz4.compression = Compression::kLz4;
  EXPECT_THROW(RecordingWriter((dir / "lz4.hprec").string(), lz4), std::invalid_argument);  // SQLite: none, zstd
  EXPECT_THROW(RecordingWriter((dir / "none.mcap").string()), RecordingError);               // never overwritten
  EXPECT_THROW(ParseStorage("rosbag"), std::invalid_argument);
}

// The layout the specification asks for: magic at both ends, a Header first, a
// Footer last; chunks each followed by their message indexes; Data End, then the
// summary grouped by opcode, summary offsets pointing at each group, and a footer
// whose summary CRC-32 matches.
TEST(McapStorage, TheFileHasTheSpecificationsLayout) {
  const auto dir = test::TempDir("mcap_layout");
  const std::string path = (dir / "a.mcap").string();
  WriteMcapStream(path, Compression::kZstd, 120, 40);
  const std::string b = test::ReadFile(path);
  const std::string magic("\x89MCAP0\r\n", 8);
  ASSERT_EQ(b.substr(0, 8), magic);
  ASSERT_EQ(b.substr(b.size() - 8), magic);
  const auto recs = TopLevel(b);
  ASSERT_GE(recs.size(), 10u);
  EXPECT_EQ(recs.front().op, 0x01);
  EXPECT_EQ(recs.back().op, 0x02);
  EXPECT_EQ(recs.back().at + 9 + 20 + 8, b.size());
  int chunks = 0, indexes_after_chunks = 0;
  size_t data_end = 0;
  for (size_t i = 0; i < recs.size(); ++i) {
    if (recs[i].op == 0x06) {
      ++chunks;
      EXPECT_EQ(recs[i + 1].op, 0x07) << "a chunk without message indexes after it";
    }
    if (recs[i].op == 0x07) ++indexes_after_chunks;
    if (recs[i].op == 0x0F) {
      data_end = i;
      break;
    }
  }
  ASSERT_GT(data_end, 0u);
  EXPECT_EQ(chunks, 3);                 // committed every 40 of 120
  EXPECT_EQ(indexes_after_chunks, 7);   // three channels in the first, two in the others
  const size_t summary_start = Le(b, recs.back().at + 9, 8);
  const size_t summary_offset_start = Le(b, recs.back().at + 17, 8);
  EXPECT_EQ(summary_start, recs[data_end].at + 9 + 4);
  // Grouped by opcode: each opcode's records are contiguous, and each group has
  // a Summary Offset naming its start and length.
  std::map<uint8_t, std::pair<size_t, size_t>> groups;
  uint8_t last = 0;
  for (size_t i = data_end + 1; i + 1 < recs.size(); ++i) {
    const auto& r = recs[i];
    if (r.at >= summary_offset_start) {
      ASSERT_EQ(r.op, 0x0E);
      const uint8_t op = uint8_t(b[r.at + 9]);
      EXPECT_EQ(groups.at(op).first, Le(b, r.at + 10, 8));
      EXPECT_EQ(groups.at(op).second, Le(b, r.at + 18, 8));
      continue;
    }
    if (r.op != last) {
      EXPECT_FALSE(groups.count(r.op)) << "opcode " << int(r.op) << " in two groups";
      groups[r.op] = {r.at, 0};
      last = r.op;
    }
    groups[r.op].second += 9 + r.len;
  }
  for (uint8_t op : {0x03, 0x04, 0x08, 0x0B, 0x0D}) EXPECT_TRUE(groups.count(op)) << int(op);
  // The footer's CRC-32 covers the summary through its own summary_offset_start.
  const uint32_t want = uint32_t(Le(b, recs.back().at + 25, 4));
  uLong crc = crc32(0L, Z_NULL, 0);
  crc = crc32(crc, reinterpret_cast<const Bytef*>(b.data() + summary_start),
              uInt(recs.back().at + 9 + 16 - summary_start));
  EXPECT_EQ(uint32_t(crc), want);
}

// Samples appended out of arrival order (a take groups them by key) across
// overlapping chunks come back in arrival order, ties in write order, as the
// SQLite storage gives them.
TEST(McapStorage, OverlappingChunksMergeInArrivalOrder) {
  const auto dir = test::TempDir("mcap_merge");
  std::vector<Sample> written;
  for (const auto& ext : {".mcap", ".hprec"}) {
    const std::string path = (dir / (std::string("a") + ext)).string();
    WriterOptions o;
    o.mcap.chunk_bytes = 2048;  // about one sample a chunk
    RecordingWriter w(path, o);
    const int64_t map = w.AddTopic(kMapTopic);
    written.clear();
    std::mt19937 rng(5);
    for (int k = 0; k < 200; ++k) {
      Sample s = StreamSample(map, k);
      s.arrival_ns = 1'000'000'000 + int64_t(rng() % 50) * 1'000'000;  // many ties, no order
      s.source_ns = k;                                                 // the write order
      written.push_back(s);
      w.Append(s);
    }
  }
  std::stable_sort(written.begin(), written.end(),
                   [](const Sample& a, const Sample& b) { return a.arrival_ns < b.arrival_ns; });
  ExpectSame(ReadAll(RecordingReader((dir / "a.mcap").string())), written);
  ExpectSame(ReadAll(RecordingReader((dir / "a.hprec").string())), written);
}

// A split set in MCAP (DIR named .mcap, or --storage mcap) reads and plays as one.
TEST(McapStorage, ASplitSetReadsAndPlaysAsOne) {
  const auto dir = test::TempDir("mcap_split");
  const std::string set = (dir / "run.mcap").string();
  std::vector<Sample> written;
  int parts = 0;
  {
    SplitWriter w(set, {100'000, 0, {}});
    const int64_t info = w.AddTopic(kInfoTopic), map = w.AddTopic(kMapTopic);
    written.push_back(StreamSample(info, 0));
    for (int k = 1; k < 300; ++k) written.push_back(StreamSample(map, k));
    for (const auto& s : written) w.Append(s);
    parts = w.parts();
  }
  EXPECT_GE(parts, 8);
  EXPECT_TRUE(std::filesystem::exists(SplitWriter::PartPath(set, 0, Storage::kMcap)));
  const RecordingReader r(set);
  ExpectSame(ReadAll(r), written);
  EXPECT_EQ(r.Info().damage, "");
  EXPECT_EQ(r.Info().storage, "mcap");
  PlayerOptions po;
  po.rate = 0;
  int64_t played = 0;
  Play(r, po, [&](const TopicInfo&, const Sample&) { ++played; });
  EXPECT_EQ(played, 300);
}

// SQLite -> MCAP -> SQLite, each compression: every sample byte for byte (CRC-32
// of each equal), topics, QoS, IDL and meta kept.
TEST(McapStorage, ConvertsBothWaysByteForByte) {
  const auto dir = test::TempDir("mcap_convert");
  const std::string src = (dir / "src.hprec").string();
  std::vector<Sample> written;
  {
    WriterOptions o;
    o.compression = Compression::kZstd;
    RecordingWriter w(src, o);
    w.SetMeta("domain", "9");
    const int64_t info = w.AddTopic(kInfoTopic), map = w.AddTopic(kMapTopic);
    written.push_back(StreamSample(info, 0));
    for (int k = 1; k < 150; ++k) written.push_back(StreamSample(map, k));
    for (const auto& s : written) w.Append(s);
  }
  for (const Compression c : {Compression::kNone, Compression::kZstd, Compression::kLz4}) {
    WriterOptions o;
    o.compression = c;
    const std::string mcap = (dir / (std::string(CompressionName(c)) + ".mcap")).string();
    const ConvertReport there = Convert(src, mcap, o);
    EXPECT_EQ(there.samples, 150);
    EXPECT_EQ(there.differ, 0);
    EXPECT_EQ(there.output_storage, "mcap");
    const std::string back = (dir / (std::string(CompressionName(c)) + "_back.hprec")).string();
    WriterOptions plain;
    const ConvertReport home = Convert(mcap, back, plain);
    EXPECT_EQ(home.differ, 0);
    EXPECT_EQ(home.input_storage, "mcap");
    const RecordingReader r(back);
    ExpectSame(ReadAll(r), written);
    EXPECT_EQ(r.topics()[0].type_description, kInfoTopic.type_description);
    EXPECT_EQ(r.topics()[1].depth, 4);
    EXPECT_EQ(r.Info().meta.at("domain"), "9");
    EXPECT_EQ(r.Info().meta.at("converted_from"), mcap);
  }
}

// A file cut at any byte opens or is refused in one line naming it; repair keeps
// every chunk before the cut, byte for byte, in order; never a changed sample.
TEST(McapStorage, AFileCutAtAnyByteRepairsToItsIntactChunks) {
  const auto dir = test::TempDir("mcap_cut");
  for (const Compression c : {Compression::kNone, Compression::kZstd}) {
    const std::string whole = (dir / (std::string("whole_") + CompressionName(c) + ".mcap")).string();
    const auto written = WriteMcapStream(whole, c, 120, 10);
    std::map<int64_t, Sample> original;
    for (const auto& s : written) original[s.arrival_ns] = s;
    const std::string bytes = test::ReadFile(whole);
    std::vector<size_t> cuts;
    for (size_t k = 0; k <= 97; ++k) cuts.push_back(bytes.size() * k / 97);
    std::mt19937 rng(33);
    for (int k = 0; k < 40; ++k) cuts.push_back(rng() % bytes.size());
    int64_t previous = -1;
    std::sort(cuts.begin(), cuts.end());
    for (size_t cut : cuts) {
      const std::string path = (dir / ("cut_" + std::to_string(cut) + ".mcap")).string();
      std::filesystem::remove(path);
      std::ofstream(path, std::ios::binary) << bytes.substr(0, cut);
      try {
        const RecordingReader r(path);
        const RecordingInfo info = r.Info();
        if (cut < bytes.size()) {
          EXPECT_TRUE(info.interrupted) << cut;
        }
      } catch (const RecordingError& e) {
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
        EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
      }
      const std::optional<test::RepairedCut> repaired = test::RepairTheCut(path, bytes, cut, 40, ".mcap", original);
      if (!repaired) continue;
      const RepairReport& rep = repaired->report;
      EXPECT_GE(rep.samples, previous) << "a longer file gave fewer samples";
      previous = rep.samples;
      // Whole chunks only: every 10 samples (one commit each).
      if (cut < bytes.size()) {
        EXPECT_EQ(rep.samples % 10, 0) << cut;
      }
      if (cut == bytes.size()) {
        EXPECT_EQ(rep.samples, 120);
        EXPECT_TRUE(rep.was_closed);
      }
    }
  }
}

// A writer killed by SIGKILL: every committed sample is there, the file says it
// was interrupted, and repair gives a closed file marked interrupted.
TEST(McapStorage, AKilledWritersFileKeepsEveryCommittedSample) {
  const auto dir = test::TempDir("mcap_kill");
  const std::string path = (dir / "killed.mcap").string();
  const pid_t pid = fork();
  if (pid == 0) {
    RecordingWriter w(path);
    const int64_t map = w.AddTopic(kMapTopic);
    for (int k = 0; k < 50; ++k) w.Append(StreamSample(map, k));
    w.Commit();
    for (int k = 50; k < 60; ++k) w.Append(StreamSample(map, k));  // never committed
    raise(SIGKILL);
  }
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  const RecordingReader killed(path);
  EXPECT_TRUE(killed.Info().interrupted);
  EXPECT_EQ(killed.Info().damage, "");
  EXPECT_EQ(ReadAll(killed).size(), 50u);
  const RepairReport rep = Repair(path, (dir / "fixed.mcap").string());
  EXPECT_FALSE(rep.was_closed);
  EXPECT_EQ(rep.samples, 50);
  const RecordingReader r((dir / "fixed.mcap").string());
  EXPECT_TRUE(r.Info().interrupted);
  EXPECT_EQ(r.Info().meta.at("repaired_from"), path);
  const auto got = ReadAll(r);
  ASSERT_EQ(got.size(), 50u);
  for (size_t k = 0; k < got.size(); ++k) EXPECT_TRUE(got[k].data == StreamSample(1, int(k)).data) << k;
}

// Files that lie: each named in one line with what is wrong; what still checks
// reads, what does not is counted, never handed out.

// This process's peak resident memory so far (VmHWM), in bytes.
int64_t PeakRss() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::atoll(line.c_str() + 6) * 1024;
  return -1;
}

// Files made to expand: 40 zstd chunks of 64 MiB (zeros around one message),
// each within the per-chunk ratio rule, an 86-KB file whose chunks all claim
// to start at time 0 while their messages are at 2^62. Every tool once
// decompressed all of them and held them at once (2.65-3.0 GB; 400 such chunks:
// std::bad_alloc at 5.5 GB). Now the chunks past the file's expansion bound
// (1024 times its bytes plus 64 MiB) are refused unread, named once, counted
// as damaged; the ones before it read; the reader's peak stays far under 1 GiB.
TEST(McapStorage, FilesMadeToExpandAreReadInBoundedMemory) {
  const auto dir = test::TempDir("mcap_expand");
  // The head of an honest file: its Header, Schema and Channel records.
  const std::string honest = (dir / "honest.mcap").string();
  int64_t map = 0;
  {
    WriterOptions o;
    o.compression = Compression::kNone;
    RecordingWriter w(honest, o);
    map = w.AddTopic(kMapTopic);
  }
  std::string b = test::ReadFile(honest);
  size_t head_end = 0;
  for (const Record& r : TopLevel(b)) {
    if (r.op == 0x0C || r.op == 0x0F) break;  // Metadata, Data End: the head is over
    head_end = r.at + 9 + r.len;
  }
  b.resize(head_end);
  // One chunk's records: a message at 2^62, then one record of opcode 0 (a
  // padding record readers skip) of zeros up to 64 MiB.
  const uint64_t kSize = uint64_t(64) << 20;
  std::string records;
  auto le = [](std::string* o, uint64_t v, int n) {
    for (int i = 0; i < n; ++i) o->push_back(char(v >> (8 * i)));
  };
  records.push_back(char(0x05));
  le(&records, 22 + 1, 8);
  le(&records, uint64_t(map), 2);
  le(&records, 1, 4);
  le(&records, uint64_t(1) << 62, 8);
  le(&records, uint64_t(1) << 62, 8);
  records.push_back('x');
  records.push_back(char(0));
  le(&records, kSize - records.size() - 8, 8);
  records.resize(kSize, char(0));
  std::string z(ZSTD_compressBound(records.size()), '\0');
  z.resize(ZSTD_compress(z.data(), z.size(), records.data(), records.size(), 19));
  const uint32_t crc = uint32_t(crc32(0, reinterpret_cast<const Bytef*>(records.data()), uInt(records.size())));
  std::string chunk;
  chunk.push_back(char(0x06));
  le(&chunk, 8 + 8 + 8 + 4 + 4 + 4 + 8 + z.size(), 8);
  le(&chunk, 0, 8);  // message_start_time: a lie
  le(&chunk, 0, 8);
  le(&chunk, kSize, 8);
  le(&chunk, crc, 4);
  le(&chunk, 4, 4);
  chunk += "zstd";
  le(&chunk, z.size(), 8);
  chunk += z;
  for (int k = 0; k < 40; ++k) b += chunk;
  const std::string path = (dir / "expand.mcap").string();
  std::ofstream(path, std::ios::binary) << b;
  const uint64_t budget = 1024 * uint64_t(b.size()) + (uint64_t(64) << 20);
  const int readable = int(budget / kSize);
  ASSERT_GE(readable, 1);
  ASSERT_LT(readable, 40) << "the file must be one that expands past its bound";
  const RecordingReader r(path);
  const RecordingInfo info = r.Info();
  EXPECT_NE(info.damage.find("(a file made to expand)"), std::string::npos) << info.damage;
  EXPECT_NE(info.damage.find("nor any chunk after it"), std::string::npos) << info.damage;
  EXPECT_EQ(info.damaged_samples, 40 - readable) << info.damage;
  int n = 0;
  r.ForEach([&](const Sample& s) {
    EXPECT_EQ(s.arrival_ns, int64_t(uint64_t(1) << 62));
    ++n;
    return true;
  });
  EXPECT_EQ(n, readable);  // the chunks within the bound: their message each
  // (Under a sanitizer freed memory stays quarantined: the peak says nothing.)
#if !defined(HULLPIPE_SANITIZED)
  EXPECT_LT(PeakRss(), int64_t(600) << 20) << "the reader held more than a few chunks at once";
#endif
}

// The writer keeps its files within the bound above: 100 samples of 1 MiB of
// zeros in 1-MiB zstd chunks (each compresses 5000-fold, within the per-chunk
// rule) would declare 100 MiB from a few hundred KB; the chunks that would break
// the file's bound are stored as they are, and every sample reads back.
TEST(McapStorage, TheWritersFilesStayWithinTheExpansionBound) {
  const auto dir = test::TempDir("mcap_expand_writer");
  const std::string path = (dir / "zeros.mcap").string();
  WriterOptions o;
  o.compression = Compression::kZstd;
  o.mcap.chunk_bytes = int64_t(1) << 20;
  std::vector<Sample> written;
  {
    RecordingWriter w(path, o);
    const int64_t map = w.AddTopic(kMapTopic);
    for (int k = 0; k < 100; ++k) {
      Sample s;
      s.topic_id = map;
      s.arrival_ns = s.source_ns = 1'000'000'000 + int64_t(k);
      s.data.assign(size_t(1) << 20, uint8_t(0));
      w.Append(s);
      written.push_back(s);
    }
  }
  const RecordingReader r(path);
  const RecordingInfo info = r.Info();
  EXPECT_EQ(info.damage, "");
  ExpectSame(ReadAll(r), written);
  const auto size = std::filesystem::file_size(path);
  EXPECT_GE(1024 * size + (uint64_t(64) << 20), uint64_t(100) << 20);
  EXPECT_LT(size, uint64_t(40) << 20) << "the chunks within the bound are still compressed";
}

TEST(McapStorage, FilesThatLieAreNamedInOneLine) {
  const auto dir = test::TempDir("mcap_lies");
  const std::string good = (dir / "good.mcap").string();
  WriteMcapStream(good, Compression::kNone, 60, 20);
  const std::string b = test::ReadFile(good);
  const auto recs = TopLevel(b);
  auto write = [&](const std::string& name, const std::string& bytes) {
    const std::string p = (dir / name).string();
    std::ofstream(p, std::ios::binary) << bytes;
    return p;
  };
  auto first = [&](uint8_t op) {
    for (const auto& r : recs)
      if (r.op == op) return r;
    ADD_FAILURE() << "no opcode " << int(op);
    return recs.front();
  };
  auto refused = [&](const std::string& path, const std::string& why) {
    try {
      RecordingReader r(path);
      ADD_FAILURE() << path << " was opened";
    } catch (const RecordingError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(path), std::string::npos) << what;
      EXPECT_NE(what.find(why), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    }
  };
  // Bad magic.
  std::string bad = b;
  bad[1] = 'X';
  const std::string not_mcap = write("magic.mcap", bad);
  EXPECT_THROW(RecordingReader{not_mcap}, RecordingError);  // then it is not SQLite either
  // A channel naming a schema that does not exist.
  bad = b;
  const Record ch = first(0x04);
  bad[ch.at + 9 + 2] = char(0x77);  // schema id 0x??77
  refused(write("schema.mcap", bad), "which does not exist");
  // A chunk whose CRC-32 lies: its samples are damage, the others read.
  bad = b;
  const Record chunk = first(0x06);
  bad[chunk.at + 9 + 24] ^= 0x5A;  // uncompressed_crc
  {
    const RecordingReader r(write("crc.mcap", bad));
    const RecordingInfo info = r.Info();
    EXPECT_NE(info.damage.find("CRC-32"), std::string::npos) << info.damage;
    EXPECT_EQ(info.damaged_samples, 20);
    EXPECT_EQ(ReadAll(r).size(), 40u);
  }
  // A chunk whose declared uncompressed size lies (2^40: no allocation follows it).
  bad = b;
  for (int i = 0; i < 8; ++i) bad[chunk.at + 9 + 16 + size_t(i)] = i == 5 ? 1 : 0;
  {
    const RecordingReader r(write("size.mcap", bad));
    const RecordingInfo info = r.Info();
    EXPECT_NE(info.damage.find("declared"), std::string::npos) << info.damage;
    EXPECT_EQ(ReadAll(r).size(), 40u);
  }
  // A record whose length runs past the end of the file.
  bad = b;
  const Record meta = first(0x0C);
  for (int i = 0; i < 8; ++i) bad[meta.at + 1 + size_t(i)] = char(0x7F);
  {
    const RecordingReader r(write("length.mcap", bad));
    EXPECT_NE(r.Info().damage.find("past the end"), std::string::npos) << r.Info().damage;
  }
  // A compressed chunk whose zstd frame is garbage.
  const std::string zpath = (dir / "z.mcap").string();
  WriteMcapStream(zpath, Compression::kZstd, 60, 20);
  bad = test::ReadFile(zpath);
  Record zchunk{};
  for (const auto& r : TopLevel(bad))
    if (r.op == 0x06) {
      zchunk = r;
      break;
    }
  ASSERT_GT(zchunk.at, 0u);
  for (size_t i = 0; i < 16; ++i) bad[zchunk.at + 9 + 8 * 3 + 4 + 4 + 4 + 8 + i] ^= char(0xA5);
  {
    const RecordingReader r(write("frame.mcap", bad));
    EXPECT_NE(r.Info().damage.find("decompress"), std::string::npos) << r.Info().damage;
    EXPECT_LE(ReadAll(r).size(), 40u);
  }
}

}  // namespace
}  // namespace hullpipe
