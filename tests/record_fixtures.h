// Fixtures of the recording tests (record_test.cc, record_storage_test.cc,
// record_mcap_test.cc): topics, a synthetic sample stream and read-back helpers
// shared by the SQLite and MCAP storages' tests (docs/recording.md).
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "hullpipe/record/recording.h"
#include "hullpipe/record/repair.h"
#include "test_util.h"

namespace hullpipe::test {

/// A latched, keyed CameraInfo topic with its IDL text (as the recorder stores it).
inline const record::TopicInfo kInfoTopic{0, "hullpipe/camera_info", "hullpipe::msg::CameraInfo", true, true, true, 1,
                                          "module hullpipe { module msg { @final struct CameraInfo { long x; }; }; };"};
/// A keyed, unlatched map topic of depth 4.
inline const record::TopicInfo kMapTopic{
    0,
    "hullpipe/object_pixel_map",
    "hullpipe::msg::ObjectPixelMap",
    true,
    true,
    false,
    4,
    "module hullpipe { module msg { @final struct ObjectPixelMap { long y; }; }; };"};
/// An unkeyed topic with no IDL text.
inline const record::TopicInfo kPoseTopic{0, "hullpipe/head_pose", "hullpipe::msg::HeadPose", false, false, false, 1,
                                          ""};

/// Sample k of a synthetic stream on `topic`: arrival 1 s + k * 10 ms, source
/// time 777 ns earlier, 40..6000 bytes (some spill over SQLite pages), even k
/// compressible and odd k random.
inline record::Sample StreamSample(int64_t topic, int k) {
  record::Sample s;
  s.topic_id = topic;
  s.arrival_ns = 1'000'000'000 + int64_t(k) * 10'000'000;
  s.source_ns = s.arrival_ns - 777;
  std::mt19937 rng{uint32_t(k)};
  s.data.resize(40 + size_t(rng() % 6000));
  for (size_t i = 0; i < s.data.size(); ++i) s.data[i] = k % 2 ? uint8_t(rng()) : uint8_t(i / 64 + k);
  return s;
}

/// Every sample `r` reads (of the topics `ids`, or all), in its order.
inline std::vector<record::Sample> ReadAll(const record::RecordingReader& r,
                                           const std::optional<std::vector<int64_t>>& ids = {}) {
  std::vector<record::Sample> out;
  r.ForEach(
      [&](const record::Sample& s) {
        out.push_back(s);
        return true;
      },
      ids);
  return out;
}

/// What every storage's repair owes a file cut short (docs/recording.md,
/// "Repair"): `path` holds `bytes` up to `cut`; it repairs into
/// path + ".repaired" + extension, leaves its input as it was, and the repaired
/// file reads whole, its samples as the report counts, each one of `original`
/// (by arrival) unchanged, in arrival order. nullopt where repair refused the
/// file, as it may only before `header_bytes` (the cut took the storage's
/// header); then the one error names the file.
struct RepairedCut {
  record::RepairReport report;
  std::vector<record::Sample> samples;
};
inline std::optional<RepairedCut> RepairTheCut(const std::string& path, const std::string& bytes, size_t cut,
                                               size_t header_bytes, const std::string& extension,
                                               const std::map<int64_t, record::Sample>& original) {
  const std::string fixed = path + ".repaired" + extension;
  std::filesystem::remove(fixed);
  RepairedCut out;
  try {
    out.report = record::Repair(path, fixed);
  } catch (const record::RecordingError& e) {
    EXPECT_LT(cut, header_bytes) << "a file with its header was not repaired: " << e.what();
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    return std::nullopt;
  }
  EXPECT_EQ(ReadFile(path), bytes.substr(0, cut)) << "repair changed its input";
  const record::RecordingReader r(fixed);
  out.samples = ReadAll(r);
  EXPECT_EQ(int64_t(out.samples.size()), out.report.samples) << cut;
  EXPECT_EQ(r.Info().damage, "") << cut;
  for (size_t i = 0; i < out.samples.size(); ++i) {
    const auto it = original.find(out.samples[i].arrival_ns);
    if (it == original.end()) {
      ADD_FAILURE() << "cut " << cut << ": a sample that was never written";
      break;
    }
    EXPECT_TRUE(it->second.data == out.samples[i].data) << "cut " << cut << ": a changed sample";
    if (i) {
      EXPECT_LT(out.samples[i - 1].arrival_ns, out.samples[i].arrival_ns) << "cut " << cut << ": out of order";
    }
  }
  return out;
}

/// Expects `a` and `b` to hold the same samples in the same order, byte for byte.
inline void ExpectSame(const std::vector<record::Sample>& a, const std::vector<record::Sample>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].topic_id, b[i].topic_id) << i;
    EXPECT_EQ(a[i].arrival_ns, b[i].arrival_ns) << i;
    EXPECT_EQ(a[i].source_ns, b[i].source_ns) << i;
    EXPECT_TRUE(a[i].data == b[i].data) << "sample " << i << " differs";
  }
}

}  // namespace hullpipe::test
