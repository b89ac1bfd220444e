// Recording storage (docs/recording.md), the library alone: compression, a split
// recording read as one, the snapshot window, and repair of files cut at any byte.
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>

#include <gtest/gtest.h>
#include <zstd.h>

#include "hullpipe/record/player.h"
#include "hullpipe/record/recording.h"
#include "hullpipe/record/repair.h"
#include "hullpipe/record/snapshot.h"
#include "hullpipe/record/split_writer.h"
#include "record_fixtures.h"
#include "test_util.h"

namespace hullpipe {
namespace {

using namespace hullpipe::record;
using test::ExpectSame;
using test::kInfoTopic;
using test::kMapTopic;
using test::ReadAll;
using test::StreamSample;

// Writes a CameraInfo then n - 1 maps of the stream to a new recording at
// `path`, committing every `commit_every`; returns what was written.
std::vector<Sample> WriteMapStream(const std::string& path, Compression c, int n, int commit_every) {
  WriterOptions o;
  o.compression = c;
  RecordingWriter w(path, o);
  const int64_t info = w.AddTopic(kInfoTopic), map = w.AddTopic(kMapTopic);
  std::vector<Sample> written{StreamSample(info, 0)};
  for (int k = 1; k < n; ++k) written.push_back(StreamSample(map, k));
  for (size_t k = 0; k < written.size(); ++k) {
    w.Append(written[k]);
    if (int(k) % commit_every == commit_every - 1) w.Commit();
  }
  return written;
}


// A zstd frame of ~40 KB that really gives 1 GiB (run-length blocks of
// zeros) made `info` allocate 1.1 GB on an 8-MB file: refused by the ratio
// rule without allocating. Controls: 2 MiB of zeros (under the ratio-free
// 64 MiB) decodes; a frame cut short fails.
TEST(RecordingStorage, AZstdFrameThatExpandsAbsurdlyIsRefusedWithoutAllocating) {
  std::unique_ptr<ZSTD_CCtx, size_t (*)(ZSTD_CCtx*)> c(ZSTD_createCCtx(), ZSTD_freeCCtx);
  ZSTD_CCtx_setParameter(c.get(), ZSTD_c_compressionLevel, 1);
  const int64_t claimed = kMaxSampleBytes;
  ZSTD_CCtx_setPledgedSrcSize(c.get(), uint64_t(claimed));
  const std::vector<uint8_t> zeros(1 << 20, 0);
  std::vector<uint8_t> frame(1 << 20);
  ZSTD_outBuffer out{frame.data(), frame.size(), 0};
  for (int64_t done = 0; done < claimed; done += int64_t(zeros.size())) {
    ZSTD_inBuffer in{zeros.data(), zeros.size(), 0};
    const bool last = done + int64_t(zeros.size()) >= claimed;
    while (true) {
      const size_t r = ZSTD_compressStream2(c.get(), &out, &in, last ? ZSTD_e_end : ZSTD_e_continue);
      ASSERT_FALSE(ZSTD_isError(r));
      if (last ? r == 0 : in.pos == in.size) break;
    }
  }
  frame.resize(out.pos);
  ASSERT_LT(frame.size(), size_t(1) << 20);
  std::vector<uint8_t> got;
  EXPECT_FALSE(DecodeSampleData(frame.data(), frame.size(), 1, claimed, &got));
  EXPECT_LT(got.capacity(), size_t(1) << 20) << "refused before allocating";
  EXPECT_FALSE(ZstdRatioPlausible(frame.size(), claimed));

  const std::vector<uint8_t> small(2 << 20, 0);
  std::vector<uint8_t> packed(ZSTD_compressBound(small.size()));
  packed.resize(ZSTD_compress(packed.data(), packed.size(), small.data(), small.size(), 1));
  ASSERT_TRUE(DecodeSampleData(packed.data(), packed.size(), 1, int64_t(small.size()), &got));
  EXPECT_EQ(got, small);
  EXPECT_FALSE(DecodeSampleData(packed.data(), packed.size() / 2, 1, int64_t(small.size()), &got)) << "cut short";
}

// zstd per sample: what is read back is byte for byte what was written (the CRC
// covers the decompressed bytes); compressible samples shrink, random ones are
// stored as they are; info says so.
TEST(RecordingStorage, ZstdRoundTripsByteForByte) {
  const auto dir = test::TempDir("rec_zstd");
  std::vector<Sample> written;
  for (const Compression c : {Compression::kNone, Compression::kZstd}) {
    const std::string path = (dir / (std::string(CompressionName(c)) + ".hprec")).string();
    written = WriteMapStream(path, c, 200, 1000);
    const RecordingReader r(path);
    ExpectSame(ReadAll(r), written);
    const RecordingInfo info = r.Info();
    EXPECT_EQ(info.damage, "");
    EXPECT_EQ(info.compression, CompressionName(c));
    EXPECT_EQ(info.format, "hullpipe-recording-3");
    EXPECT_EQ(r.topics()[0].type_description, kInfoTopic.type_description);
    int64_t bytes = 0;
    for (const auto& s : written) bytes += int64_t(s.data.size());
    EXPECT_EQ(info.bytes, bytes);
    if (c == Compression::kZstd) {
      // Half the samples are runs of 64 equal bytes: far smaller; the random half
      // is stored as it is, so the total lies between a quarter and 0.6 of it.
      EXPECT_LT(info.stored_bytes, bytes * 6 / 10);
      EXPECT_GT(info.stored_bytes, bytes / 4);
    } else {
      EXPECT_EQ(info.stored_bytes, bytes);
    }
  }
  WriterOptions bad;
  bad.zstd_level = 0;
  EXPECT_THROW(RecordingWriter((dir / "bad.hprec").string(), bad), std::invalid_argument);
  EXPECT_THROW(ParseCompression("lz5"), std::invalid_argument);
}

// A recording split by size and by duration reads as one: the same samples in
// the same order, the same topics, and a player plays it through.
TEST(RecordingStorage, ASplitRecordingReadsAndPlaysAsOne) {
  const auto dir = test::TempDir("rec_split");
  std::vector<Sample> written;
  const std::string single = (dir / "single.hprec").string();
  {
    RecordingWriter w(single);
    const int64_t info = w.AddTopic(kInfoTopic), map = w.AddTopic(kMapTopic);
    written.push_back(StreamSample(info, 0));
    for (int k = 1; k < 300; ++k) written.push_back(StreamSample(map, k));
    for (const auto& s : written) w.Append(s);
  }
  for (const auto& [name, opt] : std::vector<std::pair<std::string, SplitOptions>>{
           {"by_size", {100'000, 0, {}}}, {"by_duration", {0, 0.5, {Compression::kZstd, 3}}}}) {
    const std::string set = (dir / name).string();
    int parts = 0;
    {
      SplitWriter w(set, opt);
      w.SetMeta("domain", "7");
      const int64_t info = w.AddTopic(kInfoTopic), map = w.AddTopic(kMapTopic);
      for (auto s : written) {
        s.topic_id = s.topic_id == 1 ? info : map;
        w.Append(s);
      }
      parts = w.parts();
    }
    // 300 samples of ~3 KB (~900 KB) in 100 KB parts; 3 s in 0.5 s parts.
    EXPECT_GE(parts, name == "by_size" ? 8 : 6) << name;
    EXPECT_EQ(int(std::distance(std::filesystem::directory_iterator(set), {})), parts);
    const RecordingReader r(set);
    EXPECT_EQ(r.files().size(), size_t(parts));
    ASSERT_EQ(r.topics().size(), 2u);
    EXPECT_EQ(r.topics()[0].name, kInfoTopic.name);
    ExpectSame(ReadAll(r), written);
    const RecordingInfo info = r.Info();
    EXPECT_EQ(info.damage, "") << name;
    EXPECT_EQ(info.samples, 300);
    EXPECT_EQ(info.meta.at("domain"), "7");
    EXPECT_FALSE(info.interrupted);
    EXPECT_EQ(r.LastArrivalNs().value(), written.back().arrival_ns);
    PlayerOptions po;
    po.rate = 0;
    int64_t played = 0;
    Play(r, po, [&](const TopicInfo&, const Sample&) { ++played; });
    EXPECT_EQ(played, 300);
    // A missing part is damage that info names; the rest still reads.
    if (name == "by_size") {
      const std::string gap = (dir / "gap").string();
      std::filesystem::copy(set, gap);
      std::filesystem::remove(SplitWriter::PartPath(gap, 2));
      const RecordingReader g(gap);
      EXPECT_NE(g.Info().damage.find("part 2 missing"), std::string::npos) << g.Info().damage;
    }
  }
  // Files of two recordings in one directory: refused, naming the directory.
  const std::string mixed = (dir / "mixed").string();
  std::filesystem::create_directory(mixed);
  std::filesystem::copy(SplitWriter::PartPath((dir / "by_size").string(), 0), mixed + "/a.hprec");
  std::filesystem::copy(SplitWriter::PartPath((dir / "by_duration").string(), 1), mixed + "/b.hprec");
  try {
    RecordingReader r(mixed);
    ADD_FAILURE() << "a directory of two recordings was read";
  } catch (const RecordingError& e) {
    EXPECT_NE(std::string(e.what()).find("2 recordings"), std::string::npos) << e.what();
  }
  EXPECT_THROW(SplitWriter((dir / "by_size").string(), {}), RecordingError);  // never overwritten
  EXPECT_THROW(SplitWriter((dir / "x").string(), {100, 0, {}}), std::invalid_argument);
}

// The snapshot holds exactly the samples of the last N seconds before the
// trigger, plus the calibration a replay needs, and never more than its bytes.
TEST(RecordingStorage, ASnapshotHoldsExactlyTheLastNSeconds) {
  SnapshotOptions o;
  o.seconds = 2.0;
  SnapshotBuffer b(o);
  TopicInfo info = kInfoTopic, map = kMapTopic;
  info.id = 1;
  map.id = 2;
  b.AddTopic(info);
  b.AddTopic(map);
  for (int cam = 0; cam < 4; ++cam) {  // calibration of four cameras, at the start
    Sample s = StreamSample(1, 0);
    s.data.assign(100, uint8_t(cam));
    b.Add(s);
  }
  for (int k = 1; k <= 1000; ++k) b.Add(StreamSample(2, k));  // 10 s at 100 Hz
  const int64_t trigger = StreamSample(2, 1000).arrival_ns + 5'000'000;  // 5 ms after the last
  b.TrimTo(trigger);
  const auto got = b.Contents();
  // Window [trigger - 2 s, trigger]: samples k with 10 ms * k >= 10 s + 5 ms - 2 s,
  // i.e. k = 801..1000 (k = 800 arrived 5 ms too early).
  ASSERT_EQ(got.size(), 4u + 200u);
  for (int cam = 0; cam < 4; ++cam) EXPECT_EQ(got[size_t(cam)].data[0], cam);
  for (size_t i = 4; i < got.size(); ++i) {
    EXPECT_EQ(got[i].topic_id, 2);
    EXPECT_EQ(got[i].arrival_ns, StreamSample(2, 801 + int(i) - 4).arrival_ns);
    EXPECT_GE(got[i].arrival_ns, trigger - 2'000'000'000);
  }
  int64_t bytes = 0;
  for (const auto& s : got) bytes += int64_t(s.data.size());
  EXPECT_EQ(b.bytes(), bytes);
  // The byte bound drops the oldest first, and is never exceeded.
  SnapshotOptions small = o;
  small.max_bytes = 100'000;
  SnapshotBuffer c(small);
  c.AddTopic(map);
  for (int k = 1; k <= 1000; ++k) {
    c.Add(StreamSample(2, k));
    ASSERT_LE(c.bytes(), small.max_bytes);
  }
  const auto kept = c.Contents();
  EXPECT_EQ(kept.back().arrival_ns, StreamSample(2, 1000).arrival_ns);
  EXPECT_GT(c.dropped_for_bytes(), 0);
  EXPECT_THROW(c.Add(StreamSample(9, 1)), std::invalid_argument);
  SnapshotOptions zero = o;
  zero.seconds = 0;
  EXPECT_THROW(SnapshotBuffer{zero}, std::invalid_argument);
}


// A file cut at any byte opens (or is refused in one line), repairs, and the
// repaired file replays exactly the samples it holds: each one byte for byte the
// original, in order; never a changed one. The input is never modified.
TEST(RecordingStorage, AFileCutAtAnyByteOpensRepairsAndReplaysWhatItHolds) {
  const auto dir = test::TempDir("rec_cut");
  std::map<int64_t, Sample> original;  // by arrival
  std::vector<Sample> written;
  for (const Compression c : {Compression::kNone, Compression::kZstd}) {
    const std::string whole = (dir / (std::string("whole_") + CompressionName(c) + ".hprec")).string();
    written = WriteMapStream(whole, c, 120, 10);
    for (const auto& s : written) original[s.arrival_ns] = s;
    const std::string bytes = test::ReadFile(whole);
    // Every 1/97th of the file, and 40 random cuts.
    std::vector<size_t> cuts;
    for (size_t k = 0; k <= 97; ++k) cuts.push_back(bytes.size() * k / 97);
    std::mt19937 rng(18);
    for (int k = 0; k < 40; ++k) cuts.push_back(rng() % bytes.size());
    int64_t recovered_at_full = 0;
    for (size_t cut : cuts) {
      const std::string path = (dir / ("cut_" + std::to_string(cut) + ".hprec")).string();
      std::filesystem::remove(path);
      std::ofstream(path, std::ios::binary) << bytes.substr(0, cut);
      try {
        const RecordingReader r(path);  // opens, or one error naming the file
        (void)r.Info();
      } catch (const RecordingError& e) {
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      }
      const std::optional<test::RepairedCut> repaired = test::RepairTheCut(path, bytes, cut, 100, ".hprec", original);
      if (!repaired) continue;
      if (cut == bytes.size()) {
        recovered_at_full = repaired->report.samples;
        EXPECT_FALSE(RecordingReader(path + ".repaired.hprec").Info().interrupted);  // it was closed
      }
    }
    EXPECT_EQ(recovered_at_full, int64_t(written.size())) << CompressionName(c);
  }
}

// A recorder killed by SIGKILL: its file and log repair to every committed
// sample, and the repaired file says it was interrupted (info of the original
// says so too and never changes it).
TEST(RecordingStorage, AKilledWritersFileRepairsToItsCommittedSamplesMarkedInterrupted) {
  const auto dir = test::TempDir("rec_kill_repair");
  const std::string path = (dir / "killed.hprec").string();
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
  ASSERT_TRUE(std::filesystem::exists(path + "-wal"));
  const std::string db = test::ReadFile(path), wal = test::ReadFile(path + "-wal");
  EXPECT_TRUE(RecordingReader(path).Info().interrupted);
  const RepairReport rep = Repair(path, (dir / "fixed.hprec").string());
  EXPECT_FALSE(rep.was_closed);
  EXPECT_GE(rep.samples, 50);
  const RecordingReader r((dir / "fixed.hprec").string());
  const RecordingInfo info = r.Info();
  EXPECT_TRUE(info.interrupted);
  EXPECT_EQ(info.meta.at("repaired_from"), path);
  const auto got = ReadAll(r);
  ASSERT_GE(got.size(), 50u);
  for (size_t k = 0; k < got.size(); ++k) EXPECT_TRUE(got[k].data == StreamSample(1, int(k)).data) << k;
  EXPECT_EQ(test::ReadFile(path), db);
  EXPECT_EQ(test::ReadFile(path + "-wal"), wal);
  EXPECT_THROW(Repair(path, (dir / "fixed.hprec").string()), RecordingError);  // never overwritten
  EXPECT_THROW(Repair((dir / "none.hprec").string(), (dir / "o.hprec").string()), RecordingError);
}

}  // namespace
}  // namespace hullpipe
