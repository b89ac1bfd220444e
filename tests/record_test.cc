// Recording and replaying DDS traffic (docs/recording.md). The recording library and the
// player alone (no transport: a fake clock and a vector as the sink), then the
// tools as processes, each test on its own DDS domain on loopback: a replay is
// byte-identical to what was recorded and late joiners get the transient-local
// CameraInfo; a recorder killed by SIGKILL leaves a file that opens; replaying
// one recording twice into sim_node gives identical CollisionReports.
#include <signal.h>
#include <sys/wait.h>

#include <sqlite3.h>

#include <algorithm>
#include <atomic>
#include <fstream>
#include <random>
#include <map>
#include <set>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/videoio.hpp>

#include "hullpipe/geometry/calibration.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/record/player.h"
#include "hullpipe/record/recording.h"
#include "test_util.h"

namespace hullpipe {
namespace {

using namespace hullpipe::record;

Sample MakeSample(int64_t topic, int64_t t_ns, uint8_t fill, size_t n = 16) {
  Sample s;
  s.topic_id = topic;
  s.source_ns = t_ns - 1000;
  s.arrival_ns = t_ns;
  s.data.assign(n, fill);
  return s;
}

TEST(Recording, RoundTripInfoAndNeverOverwrites) {
  const auto dir = test::TempDir("rec_rt");
  const std::string path = (dir / "a.hprec").string();
  {
    RecordingWriter w(path);
    TopicInfo info{0, "hullpipe/camera_info", "hullpipe::msg::CameraInfo", true, true, true, 1, ""};
    const int64_t a = w.AddTopic(info);
    EXPECT_EQ(w.AddTopic(info), a);  // same name, same id
    const int64_t b =
        w.AddTopic({0, "hullpipe/object_pixel_map", "hullpipe::msg::ObjectPixelMap", true, true, false, 4, ""});
    w.Append(MakeSample(a, 1'000'000'000, 1));
    w.Append(MakeSample(b, 1'500'000'000, 2, 1000));
    w.Append(MakeSample(b, 3'000'000'000, 3, 1000));
    w.SetMeta("lost_total", "0");
  }
  EXPECT_THROW(RecordingWriter{path}, RecordingError);
  const RecordingReader r(path);
  ASSERT_EQ(r.topics().size(), 2u);
  EXPECT_TRUE(r.topics()[0].transient_local);
  EXPECT_EQ(r.topics()[1].depth, 4);
  std::vector<Sample> got;
  r.ForEach([&](const Sample& s) {
    got.push_back(s);
    return true;
  });
  ASSERT_EQ(got.size(), 3u);
  EXPECT_EQ(got[1].data, std::vector<uint8_t>(1000, 2));
  EXPECT_EQ(got[2].source_ns, 3'000'000'000 - 1000);
  const RecordingInfo info = r.Info();
  EXPECT_EQ(info.samples, 3);
  EXPECT_EQ(info.bytes, 16 + 2000);
  EXPECT_DOUBLE_EQ(info.duration_s(), 2.0);
  EXPECT_EQ(info.meta.at("lost_total"), "0");
  EXPECT_THROW(RecordingReader{(dir / "missing.hprec").string()}, RecordingError);
}

TEST(Recording, AWriterKilledBySigkillLosesOnlyItsLastBatch) {
  const auto dir = test::TempDir("rec_kill");
  const std::string path = (dir / "k.hprec").string();
  const pid_t pid = fork();
  if (pid == 0) {
    RecordingWriter w(path);
    const int64_t t = w.AddTopic({0, "x", "hullpipe::msg::CameraInfo", false, true, false, 1, ""});
    for (int batch = 0; batch < 5; ++batch) {
      for (int k = 0; k < 10; ++k) w.Append(MakeSample(t, (batch * 10 + k + 1) * 1000, uint8_t(k)));
      w.Commit();
    }
    for (int k = 0; k < 7; ++k) w.Append(MakeSample(t, 1'000'000 + k, 9));  // the open batch
    raise(SIGKILL);
  }
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL);
  const RecordingReader r(path);
  EXPECT_EQ(r.Info().samples, 50);  // the five committed batches, not the open one
}

// A file made with SQLite directly: `sql` run on a new database.
std::string MakeDb(const std::filesystem::path& dir, const std::string& name, const std::string& sql) {
  const std::string path = (dir / name).string();
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  char* err = nullptr;
  EXPECT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err), SQLITE_OK) << (err ? err : "");
  sqlite3_free(err);
  sqlite3_close(db);
  return path;
}

// The tables of the format, without the writer's NOT NULL constraints.
const char* kLooseTables =
    "CREATE TABLE meta(key TEXT PRIMARY KEY, value TEXT);"
    "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT, type TEXT, keyed INTEGER, reliable INTEGER,"
    " transient_local INTEGER, depth INTEGER);";

// Files that are not (whole) recordings: one RecordingError naming the file and
// what is wrong, never a crash or a bare SQLite message.
std::map<std::string, std::pair<std::string, std::string>> BadRecordings(const std::filesystem::path& dir) {
  std::map<std::string, std::pair<std::string, std::string>> bad;  // case -> {path, expected words}
  const std::string empty = (dir / "empty.hprec").string();
  std::ofstream(empty).close();
  bad["empty file"] = {empty, "empty file"};
  const std::string text = (dir / "text.hprec").string();
  std::ofstream(text) << std::string(4096, 'x');
  bad["not SQLite"] = {text, "not a hullpipe recording"};
  bad["no samples table"] = {
      MakeDb(dir, "nosamples.hprec",
             std::string(kLooseTables) + "INSERT INTO meta VALUES('format', 'hullpipe-recording-2');"),
      "no table 'samples'"};
  const std::string samples =
      "CREATE TABLE samples(id INTEGER PRIMARY KEY, topic_id INTEGER, source_ns INTEGER, arrival_ns INTEGER,"
      " data BLOB, crc INTEGER);";
  bad["NULL format"] = {MakeDb(dir, "nullformat.hprec",
                               std::string(kLooseTables) + samples + "INSERT INTO meta VALUES('format', NULL);"),
                        "meta 'format' is NULL"};
  bad["NULL topic name"] = {
      MakeDb(dir, "nullname.hprec",
             std::string(kLooseTables) + samples +
                 "INSERT INTO meta VALUES('format', 'hullpipe-recording-2');"
                 "INSERT INTO topics VALUES(1, NULL, 'hullpipe::msg::CameraInfo', 1, 1, 1, 1);"),
      "topics row 1 has no name"};
  bad["NULL topic type"] = {
      MakeDb(dir, "nulltype.hprec",
             std::string(kLooseTables) + samples +
                 "INSERT INTO meta VALUES('format', 'hullpipe-recording-2');"
                 "INSERT INTO topics VALUES(1, 'hullpipe/camera_info', NULL, 1, 1, 1, 1);"),
      "topics row 1 has no type"};
  return bad;
}

TEST(Recording, BadFilesGiveOneErrorNamingTheFile) {
  const auto dir = test::TempDir("rec_bad");
  for (const auto& [what, file] : BadRecordings(dir)) {
    try {
      const RecordingReader r(file.first);
      ADD_FAILURE() << what << ": opened";
    } catch (const RecordingError& e) {
      const std::string msg = e.what();
      EXPECT_EQ(msg.rfind(file.first + ": ", 0), 0u) << what << ": " << msg;
      EXPECT_NE(msg.find(file.second), std::string::npos) << what << ": " << msg;
    }
  }
}


// A recording with `n` samples of 1000 bytes, closed by its writer.
std::string WriteRecording(const std::filesystem::path& dir, const std::string& name, int n) {
  const std::string path = (dir / name).string();
  RecordingWriter w(path);
  const int64_t t =
      w.AddTopic({0, "hullpipe/object_pixel_map", "hullpipe::msg::ObjectPixelMap", true, true, false, 4, ""});
  for (int k = 0; k < n; ++k) {
    Sample s = MakeSample(t, (k + 1) * 1'000'000, uint8_t(k), 1000);
    for (size_t i = 0; i < s.data.size(); ++i) s.data[i] = uint8_t(k * 31 + i * 7);
    w.Append(s);
    if (k % 20 == 19) w.Commit();
  }
  return path;
}

// Reading (info, replay) never writes the file; a file whose writer was killed
// says so, one whose writer closed it does not.
TEST(Recording, ReadingNeverChangesTheFileAndAKilledWriterIsMarked) {
  const auto dir = test::TempDir("rec_ro");
  const std::string closed = WriteRecording(dir, "closed.hprec", 10);
  const std::string killed = (dir / "killed.hprec").string();
  const pid_t pid = fork();
  if (pid == 0) {
    RecordingWriter w(killed);
    const int64_t t = w.AddTopic({0, "x", "hullpipe::msg::CameraInfo", false, true, false, 1, ""});
    for (int k = 0; k < 10; ++k) w.Append(MakeSample(t, (k + 1) * 1000, uint8_t(k)));
    w.Commit();
    raise(SIGKILL);
  }
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(std::filesystem::exists(killed + "-wal"));  // the commit is in the log, not yet in the file
  const std::string db = test::ReadFile(killed), wal = test::ReadFile(killed + "-wal");
  {
    const RecordingReader r(killed);
    const RecordingInfo info = r.Info();
    EXPECT_EQ(info.samples, 10);
    EXPECT_TRUE(info.interrupted);
    EXPECT_EQ(info.damage, "");
  }
  EXPECT_EQ(test::ReadFile(killed), db) << "the reader changed the file";
  EXPECT_EQ(test::ReadFile(killed + "-wal"), wal) << "the reader changed the log";
  const RecordingReader c(closed);
  EXPECT_FALSE(c.Info().interrupted);  // control
}

// Random bit flips in the middle of a file: the damage is reported (never
// plausible counts), and reading skips or stops with an error, never crashes or
// returns a changed sample.
TEST(Recording, BitFlipsAreReportedNotReadAsData) {
  const auto dir = test::TempDir("rec_flip");
  const std::string good = WriteRecording(dir, "good.hprec", 200);
  std::map<int64_t, std::vector<uint8_t>> original;  // by arrival time
  {
    const RecordingReader r(good);
    EXPECT_EQ(r.Info().damage, "");  // control: the intact file is sound
    r.ForEach([&](const Sample& s) {
      original[s.arrival_ns] = s.data;
      return true;
    });
  }
  ASSERT_EQ(original.size(), 200u);
  std::mt19937 rng(16);
  int reported = 0;
  const int kFiles = 20;
  for (int f = 0; f < kFiles; ++f) {
    std::string bytes = test::ReadFile(good);
    std::uniform_int_distribution<size_t> at(bytes.size() / 4, bytes.size() * 3 / 4);
    for (int k = 0; k < 8; ++k) bytes[at(rng)] ^= char(1 << (rng() % 8));
    const std::string path = (dir / ("flip" + std::to_string(f) + ".hprec")).string();
    std::ofstream(path, std::ios::binary) << bytes;
    bool found = false;
    try {
      const RecordingReader r(path);
      found = !r.Info().damage.empty();
      r.ForEach([&](const Sample& s) {
        const auto it = original.find(s.arrival_ns);
        EXPECT_TRUE(it != original.end() && it->second == s.data) << "file " << f << ": a changed sample was read";
        return true;
      });
    } catch (const RecordingError& e) {
      found = true;  // one line naming the file
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
    reported += found;
  }
  // Every flipped file was found damaged (flips landing in unused bytes of a
  // page could go unseen; none did with this seed).
  EXPECT_EQ(reported, kFiles);
}

// A clock that only moves when the player sleeps.
struct FakeClock : PlayerClock {
  double t = 100.0;
  double Now() override { return t; }
  void SleepFor(double s) override { t += s; }
};

// The players' recording: a CameraInfo at 0 s (fill 1), then a map every 0.5 s
// to 2 s (fills 1..4).
std::string WritePlayerRecording(const std::filesystem::path& dir) {
  const std::string path = (dir / "p.hprec").string();
  {
    RecordingWriter w(path);
    const int64_t info = w.AddTopic({0, "hullpipe/camera_info", "T", true, true, true, 1, ""});
    const int64_t maps = w.AddTopic({0, "hullpipe/object_pixel_map", "T", true, true, false, 4, ""});
    w.Append(MakeSample(info, 0, 1));
    for (int k = 1; k <= 4; ++k) w.Append(MakeSample(maps, int64_t(k) * 500'000'000, uint8_t(k)));  // every 0.5 s
  }
  return path;
}

TEST(Player, TimingRateOffsetLoopAndFilters) {
  const auto dir = test::TempDir("player");
  const std::string path = WritePlayerRecording(dir);
  const RecordingReader r(path);
  struct Played {
    std::string topic;
    double at;
  };
  auto play = [&](const PlayerOptions& o) {
    FakeClock clock;
    std::vector<Played> out;
    Play(r, o, [&](const TopicInfo& t, const Sample&) { out.push_back({t.name, clock.t - 100.0}); }, nullptr, &clock);
    return out;
  };
  PlayerOptions o;
  auto p = play(o);
  ASSERT_EQ(p.size(), 5u);
  EXPECT_NEAR(p[4].at, 2.0, 1e-9);  // original timing
  o.rate = 2;
  EXPECT_NEAR(play(o)[4].at, 1.0, 1e-9);  // twice as fast
  o.rate = 0;
  EXPECT_NEAR(play(o)[4].at, 0.0, 1e-9);  // unpaced
  // Offset 1.2 s: maps at 1.5 and 2.0 s remain; the transient-local CameraInfo
  // from before the offset is still played first, at once.
  o.rate = 1;
  o.start_offset_s = 1.2;
  p = play(o);
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p[0].topic, "hullpipe/camera_info");
  EXPECT_NEAR(p[2].at - p[1].at, 0.5, 1e-9);
  o.start_offset_s = 0;
  o.exclude = {"*camera_info"};
  EXPECT_EQ(play(o).size(), 4u);
  o.exclude.clear();
  o.loop = true;
  o.max_loops = 3;
  EXPECT_EQ(play(o).size(), 15u);
  // Pause with two steps, then stop.
  PlayerControl control;
  control.paused = true;
  control.steps = 2;
  FakeClock clock;
  std::atomic<int> n{0};  // read by the stopper thread (TSan found the plain int)
  std::thread stopper([&] {
    while (n.load() < 2) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    control.stop = true;
  });
  PlayerOptions once;
  const PlayStats st = Play(r, once, [&](const TopicInfo&, const Sample&) { ++n; }, &control, &clock);
  stopper.join();
  EXPECT_EQ(st.samples, 2);
}

// An end offset, a seek and a rate change while playing (what the command topic
// and the keyboard ask for), against the recording's own timing.
TEST(Player, EndSeekAndRateChanges) {
  const auto dir = test::TempDir("player_seek");
  const std::string path = WritePlayerRecording(dir);
  const RecordingReader r(path);
  struct Played {
    uint8_t fill;
    double at;
  };
  // Plays with `o`; `on` is called after each sample with the control.
  auto play = [&](const PlayerOptions& o, const std::function<void(const Sample&, PlayerControl&)>& on) {
    FakeClock clock;
    PlayerControl control;
    std::vector<Played> out;
    const PlayStats st = Play(r, o, [&](const TopicInfo&, const Sample& s) {
      out.push_back({s.data[0], clock.t - 100.0});
      on(s, control);
    }, &control, &clock);
    return std::make_pair(out, st);
  };
  auto nothing = [](const Sample&, PlayerControl&) {};
  PlayerOptions o;
  o.end_offset_s = 1.2;  // CameraInfo at 0, maps at 0.5 and 1.0
  auto [p, st] = play(o, nothing);
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p.back().fill, 2);
  o.end_offset_s = 0;
  // At the map of 0.5 s, seek to 1.9 s: the CameraInfo again (state before the
  // seek point), then the map of 2.0 s, 0.1 s of recording later.
  std::tie(p, st) = play(o, [](const Sample& s, PlayerControl& c) {
    if (s.data[0] == 1 && s.arrival_ns == 500'000'000) c.seek_s = 1.9;
  });
  ASSERT_EQ(p.size(), 4u);
  EXPECT_EQ(p[2].fill, 1);  // CameraInfo
  EXPECT_EQ(p[3].fill, 4);  // the map of 2.0 s
  EXPECT_NEAR(p[3].at - p[1].at, 0.0, 1e-9);  // the pass restarts its clock at the seek point
  EXPECT_EQ(st.seeks, 1);
  // At 0.5 s, twice as fast: the next maps 0.25 s apart.
  std::tie(p, st) = play(o, [](const Sample& s, PlayerControl& c) {
    if (s.data[0] == 1 && s.arrival_ns == 500'000'000) c.new_rate = 2.0;
  });
  ASSERT_EQ(p.size(), 5u);
  EXPECT_NEAR(p[2].at - p[1].at, 0.25, 1e-9);
  EXPECT_NEAR(p[4].at - p[1].at, 0.75, 1e-9);
  // Twice as fast from 0.75 s, half-way through the gap before the map of 1.0 s:
  // the rest of that gap (0.25 s of recording) takes 0.125 s.
  {
    struct RateClock : FakeClock {
      PlayerControl* control = nullptr;
      void SleepFor(double dt) override {
        const bool before = t < 100.75;
        FakeClock::SleepFor(dt);
        if (before && t >= 100.75) control->new_rate = 2.0;
      }
    } clock;
    PlayerControl control;
    clock.control = &control;
    std::vector<double> at;
    Play(r, o, [&](const TopicInfo&, const Sample&) { at.push_back(clock.t - 100.0); }, &control, &clock);
    ASSERT_EQ(at.size(), 5u);
    EXPECT_NEAR(at[2], 0.875, kSleepSliceS / 2 + 1e-9);  // the request is seen within a sleep slice
    EXPECT_NEAR(at[3] - at[2], 0.25, 1e-9);
  }
  // The position a relative seek counts from: the last sample played.
  {
    PlayerControl control;
    FakeClock clock;
    Play(r, o, [](const TopicInfo&, const Sample&) {}, &control, &clock);
    EXPECT_NEAR(control.position_s.load(), 2.0, 1e-9);
  }
  // A rate out of bounds is refused and counted; the timing stays.
  std::tie(p, st) = play(o, [](const Sample& s, PlayerControl& c) {
    if (s.arrival_ns == 500'000'000) c.new_rate = 1e9;
  });
  EXPECT_EQ(st.refused_requests, 1);
  EXPECT_NEAR(p[4].at, 2.0, 1e-9);
  // A seek past the end ends the pass.
  std::tie(p, st) = play(o, [](const Sample& s, PlayerControl& c) {
    if (s.arrival_ns == 500'000'000) c.seek_s = 99;
  });
  EXPECT_EQ(p.size(), 2u);  // CameraInfo and the map of 0.5 s
  o.start_offset_s = 1.0;
  o.end_offset_s = 0.5;
  EXPECT_THROW(o.Check(), std::invalid_argument);
}

// A stop request during a long wait between samples (rate 0.001: 17 min of gap)
// is honoured within one sleep slice, not after the gap.
TEST(Player, AStopEndsALongGapWithinASlice) {
  const auto dir = test::TempDir("player_gap");
  const std::string path = WriteRecording(dir, "g.hprec", 3);  // samples 1 ms apart
  const RecordingReader r(path);
  struct StoppingClock : FakeClock {
    PlayerControl* control = nullptr;
    void SleepFor(double s) override {
      FakeClock::SleepFor(s);
      if (t > 100.5) control->stop = true;  // the stop request comes 0.5 s into the gap
    }
  } clock;
  PlayerControl control;
  clock.control = &control;
  PlayerOptions o;
  o.rate = 0.001;
  int played = 0;
  Play(r, o, [&](const TopicInfo&, const Sample&) { ++played; }, &control, &clock);
  EXPECT_EQ(played, 1);
  EXPECT_LE(clock.t - 100.0, 0.5 + kSleepSliceS + 1e-9);
}

TEST(Player, BoundsOnRateAndStartOffset) {
  const auto dir = test::TempDir("player_bounds");
  const RecordingReader r(WriteRecording(dir, "b.hprec", 3));  // 2 ms long
  auto play = [&](double rate, double offset) {
    PlayerOptions o;
    o.rate = rate;
    o.start_offset_s = offset;
    FakeClock clock;
    return Play(r, o, [](const TopicInfo&, const Sample&) {}, nullptr, &clock).samples;
  };
  EXPECT_THROW(play(1, 1e30), std::invalid_argument);   // was: an overflow that replayed everything
  EXPECT_THROW(play(1, 0.5), std::invalid_argument);    // past the end
  EXPECT_THROW(play(1e-6, 0), std::invalid_argument);   // below 0.001
  EXPECT_THROW(play(-1, 0), std::invalid_argument);
  EXPECT_THROW(play(std::nan(""), 0), std::invalid_argument);
  EXPECT_EQ(play(1, 0.0015), 1);                        // control: within the recording
}

// ---- The tools as processes (DDS on loopback, a domain each).

class RecordTools : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::TempDir("rec_tools");
    config_ = test::WriteLoopbackConfig(dir_);
    setenv("CYCLONEDDS_URI", ("file://" + config_).c_str(), 1);
    domain_ = test::UniqueDomain();
  }
  std::unique_ptr<test::Process> Start(const std::string& exe, std::vector<std::string> args, uint32_t domain = 0) {
    const std::string log = (dir_ / (exe + std::to_string(++n_) + ".log")).string();
    logs_[exe] = log;
    return test::StartExe(exe, args, domain ? domain : domain_, config_, log);
  }
  std::string Log(const std::string& exe) { return test::ReadFile(logs_[exe]); }
  static void WaitFor(const std::function<bool()>& done, double timeout_s) {
    const double end = MonotonicSeconds() + timeout_s;
    while (!done() && MonotonicSeconds() < end) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }

  std::filesystem::path dir_;
  std::string config_;
  uint32_t domain_ = 0;
  int n_ = 0;
  std::map<std::string, std::string> logs_;
};

// The tools on either storage: the same tests on SQLite (.hprec) and MCAP (.mcap).
class RecordToolsOn : public RecordTools, public ::testing::WithParamInterface<std::string> {
 protected:
  const std::string& Ext() const { return GetParam(); }
};
INSTANTIATE_TEST_SUITE_P(Storage, RecordToolsOn, ::testing::Values(std::string(".hprec"), std::string(".mcap")),
                         [](const ::testing::TestParamInfo<std::string>& i) {
                           return i.param == ".mcap" ? std::string("mcap") : std::string("sqlite");
                         });

TEST_P(RecordToolsOn, ReplayIsByteIdenticalAndLateJoinersGetCameraInfo) {
  const std::string path = (dir_ / ("r" + Ext())).string();
  {
    dds::Participant p(domain_);
    dds::Writer<hullpipe_msg_CameraInfo> info(p);
    dds::Writer<hullpipe_msg_ObjectPixelMap> maps(p);
    auto recorder = Start("hullpipe_record", {"-o", path});
    // The recorder discovers both topics and its readers match ours.
    WaitFor([&] { return info.MatchedReaders() > 0 && maps.MatchedReaders() > 0; }, 20);
    ASSERT_GT(maps.MatchedReaders(), 0u) << Log("hullpipe_record");
    const auto views = test::SphereViews(2, 64, 48, Eigen::Vector3d(0, 0, -1), 0.3);
    for (const auto& v : views) info.Write(dds::CameraToMsg(v.camera, test::BigBox()));
    // Each frame acknowledged before the next: the writer keeps the last 4 per
    // camera, and a sample overwritten before the recorder's reader took it is
    // gone (a loaded CI machine lost one of 40 so).
    for (uint64_t seq = 1; seq <= 20; ++seq) {
      for (const auto& v : views)
        maps.Write(dds::MakeMapMessage({uint32_t(v.camera.id), seq, NowNs(), double(seq) / 25}, 2, v.map).msg);
      ASSERT_EQ(dds_wait_for_acks(maps.handle(), DDS_SECS(10)), DDS_RETCODE_OK);
    }
    // Acknowledged by the recorder's readers: it has every sample; it writes
    // what it holds when stopped.
    ASSERT_EQ(dds_wait_for_acks(maps.handle(), DDS_SECS(10)), DDS_RETCODE_OK);
    ASSERT_EQ(dds_wait_for_acks(info.handle(), DDS_SECS(10)), DDS_RETCODE_OK);
    EXPECT_EQ(recorder->Stop(), 0) << Log("hullpipe_record");
  }
  // `hullpipe_record info --json` reports what is in the file.
  {
    const std::string info_log = (dir_ / "info.json").string();
    test::Process info({test::BinDir() + "/hullpipe_record", "info", path, "--json"}, info_log, {},
                       info_log + ".err");
    ASSERT_EQ(info.Wait(20), 0) << test::ReadFile(info_log + ".err");
    const auto j = nlohmann::json::parse(test::ReadFile(info_log));  // stdout alone
    EXPECT_NE(j["command"].get<std::string>().find("hullpipe_record info"), std::string::npos);
    EXPECT_EQ(j["samples"].get<int>(), 42);
    std::map<std::string, int> counts;
    for (const auto& t : j["topics"]) counts[t["name"].get<std::string>()] = t["count"].get<int>();
    EXPECT_EQ(counts["hullpipe/object_pixel_map"], 40);
    EXPECT_EQ(counts["hullpipe/camera_info"], 2);
    EXPECT_EQ(j["meta"]["lost_total"], "0");
    EXPECT_GT(j["duration_s"].get<double>(), 0.0);
  }
  // What was recorded, per topic, in order.
  const RecordingReader rec(path);
  std::map<std::string, std::vector<std::vector<uint8_t>>> recorded;
  std::map<int64_t, std::string> names;
  for (const auto& t : rec.topics()) names[t.id] = t.name;
  rec.ForEach([&](const Sample& s) {
    recorded[names[s.topic_id]].push_back(s.data);
    return true;
  });
  ASSERT_EQ(recorded["hullpipe/object_pixel_map"].size(), 40u);
  ASSERT_EQ(recorded["hullpipe/camera_info"].size(), 2u);
  EXPECT_EQ(rec.Info().meta.at("lost_total"), "0");

  // Replay on a fresh domain into a serialized reader: the same bytes.
  const uint32_t d2 = test::UniqueDomain();
  dds::Participant p2(d2);
  const dds::KnownType& map_type = *dds::FindKnownType("hullpipe::msg::ObjectPixelMap");
  dds::CdrReader cdr(p2, map_type, dds::QosSpec{true, false, 64});
  auto replay = Start("hullpipe_replay", {path, "--wait-readers", "1", "--rate", "4", "--linger", "5",
                                          "--no-keyboard"}, d2);
  std::vector<std::vector<uint8_t>> got;
  WaitFor([&] {
    cdr.TakeEach([&](const std::vector<uint8_t>& b, int64_t) { got.push_back(b); });
    return got.size() >= 40;
  }, 20);
  ASSERT_EQ(got.size(), 40u) << Log("hullpipe_replay");
  // Byte for byte. A take returns samples grouped by key (camera), so compare as
  // sets (every sample differs: frame_seq and capture time).
  auto want = recorded["hullpipe/object_pixel_map"];
  std::sort(got.begin(), got.end());
  std::sort(want.begin(), want.end());
  EXPECT_TRUE(got == want);
  // A late joiner (created after the replay sent CameraInfo) still gets it:
  // the replayer's writer is transient-local, as the original was.
  dds::Reader<hullpipe_msg_CameraInfo> late(p2);
  std::set<uint32_t> cams;
  WaitFor([&] {
    late.TakeEach([&](const hullpipe_msg_CameraInfo& m, const dds_sample_info_t&) { cams.insert(m.camera_id); });
    return cams.size() >= 2;
  }, 10);
  EXPECT_EQ(cams.size(), 2u);
  EXPECT_EQ(replay->Wait(30), 0) << Log("hullpipe_replay");
}

// Maps of two cameras (CameraInfo first), `frames` frames, at `hz` (0: at once).
// Publishes `frames` frames of two cameras' maps at hz (0: as fast as acked)
// once a reader matches and ready() holds; with `stop`, goes on past `frames`
// until *stop is set (a bound of 10 minutes), counting frames into *sent.
void PublishMaps(uint32_t domain, int frames, double hz, const std::function<bool()>& ready,
                 const std::atomic<bool>* stop = nullptr, std::atomic<int>* sent = nullptr) {
  dds::Participant p(domain);
  dds::Writer<hullpipe_msg_CameraInfo> info(p);
  dds::Writer<hullpipe_msg_ObjectPixelMap> maps(p);
  const double end = MonotonicSeconds() + 20;
  while (!(info.MatchedReaders() > 0 && maps.MatchedReaders() > 0 && ready()) && MonotonicSeconds() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_GT(maps.MatchedReaders(), 0u);
  const auto views = test::SphereViews(2, 64, 48, Eigen::Vector3d(0, 0, -1), 0.3);
  for (const auto& v : views) info.Write(dds::CameraToMsg(v.camera, test::BigBox()));
  // At most hz frames a second: a frame late (a slow acknowledgement under
  // TSan) moves the next ones later instead of sending a burst to catch up.
  double next = MonotonicSeconds();
  for (int seq = 1; stop ? !*stop && seq <= 18000 : seq <= frames; ++seq) {
    if (hz > 0) {
      while (MonotonicSeconds() < next) std::this_thread::sleep_for(std::chrono::milliseconds(2));
      next = std::max(next, MonotonicSeconds()) + 1 / hz;
    }
    for (const auto& v : views)
      maps.Write(dds::MakeMapMessage({uint32_t(v.camera.id), uint64_t(seq), NowNs(), double(seq) / 25}, 2, v.map).msg);
    // Acknowledged before the next frame: nothing overwritten in the writer's
    // keep-last history before the recorder has it.
    ASSERT_EQ(dds_wait_for_acks(maps.handle(), DDS_SECS(10)), DDS_RETCODE_OK);
    if (sent) ++*sent;
  }
  ASSERT_EQ(dds_wait_for_acks(info.handle(), DDS_SECS(10)), DDS_RETCODE_OK);
}

// A compressed recording split into parts: info reads it as one (counts, dates,
// format, per-topic losses, a clean close), export round-trips the counts (a PNG
// and a JSON line per map), and the directory replays as one recording.
TEST_P(RecordToolsOn, ASplitCompressedRecordingInfosExportsAndReplaysAsOne) {
  const std::string set = (dir_ / ("split" + Ext())).string();  // split.mcap: a set of MCAP parts
  // The parts of the set (not SQLite's -wal and -shm files), in order.
  auto parts = [&] {
    std::vector<std::filesystem::path> files;
    std::error_code ec;
    for (const auto& f : std::filesystem::directory_iterator(set, ec))
      if (f.path().extension() == Ext()) files.push_back(f.path());
    std::sort(files.begin(), files.end());
    return files;
  };
  int frames = 0;  // maps of two cameras each
  {
    // Maps at 20 Hz in parts of 0.25 s (a size split is tested on the library:
    // these maps compress to a few KiB in all) until there are three parts and
    // at least 20 frames. Parts split on the recorder's arrival stamps, which a
    // slowed recorder (ThreadSanitizer) gives in bursts: a fixed second of maps
    // made only two parts there.
    auto recorder = Start("hullpipe_record", {"-o", set, "--compression", "zstd", "--split-duration", "0.25"});
    std::atomic<bool> stop{false};
    std::atomic<int> sent{0};
    std::thread publisher([&] { PublishMaps(domain_, 0, 20, [] { return true; }, &stop, &sent); });
    WaitFor([&] { return sent >= 20 && parts().size() >= 3; }, 60 * test::TimeScale());
    stop = true;
    publisher.join();
    frames = sent;
    EXPECT_EQ(recorder->Stop(), 0) << Log("hullpipe_record");
  }
  ASSERT_GE(frames, 20);
  ASSERT_GE(parts().size(), 3u) << Log("hullpipe_record");
  const int maps_sent = 2 * frames;
  const std::string info_log = (dir_ / "split_info.json").string();
  test::Process info({test::BinDir() + "/hullpipe_record", "info", set, "--json"}, info_log);
  ASSERT_EQ(info.Wait(20), 0) << test::ReadFile(info_log);
  const auto j = nlohmann::json::parse(test::ReadFile(info_log));
  EXPECT_EQ(j["samples"].get<int>(), maps_sent + 2);
  EXPECT_GT(j["files"].size(), 1u) << "not split";
  EXPECT_EQ(j["compression"], "zstd");
  EXPECT_EQ(j["format"], Ext() == ".mcap" ? "mcap" : "hullpipe-recording-3");
  EXPECT_EQ(j["storage"], Ext() == ".mcap" ? "mcap" : "sqlite");
  EXPECT_TRUE(j["closed_cleanly"].get<bool>());
  EXPECT_LT(j["stored_bytes"].get<int64_t>(), j["bytes"].get<int64_t>());
  EXPECT_NE(j["start"].get<std::string>().find("T"), std::string::npos);
  for (const auto& t : j["topics"]) EXPECT_EQ(t["lost"], 0) << t["name"];
  // Each topic carries the IDL text of its type.
  const std::string idl_log = (dir_ / "split_idl.json").string();
  test::Process idl({test::BinDir() + "/hullpipe_record", "info", set, "--json", "--idl"}, idl_log);
  ASSERT_EQ(idl.Wait(20), 0) << test::ReadFile(idl_log);
  const auto with_idl = nlohmann::json::parse(test::ReadFile(idl_log));  // (kept: the loop reads into it)
  for (const auto& t : with_idl["topics"]) EXPECT_EQ(t["type_description"], dds::IdlText()) << t["name"];
  // Export: every map a PNG and a JSON line.
  const std::string out = (dir_ / "export").string();
  const std::string export_log = (dir_ / "export.log").string();
  test::Process exp({test::BinDir() + "/hullpipe_record", "export", set, "-o", out, "--domain",
                     std::to_string(test::UniqueDomain())}, export_log);
  ASSERT_EQ(exp.Wait(60), 0) << test::ReadFile(export_log);
  const auto e = nlohmann::json::parse(test::ReadFile(out + "/export.json"));
  const auto& maps = e["topics"]["hullpipe/object_pixel_map"];
  EXPECT_EQ(maps["samples"], maps_sent);
  EXPECT_EQ(maps["pngs"], maps_sent);
  EXPECT_EQ(maps["json_lines"], maps_sent);
  EXPECT_EQ(maps["undecodable"], 0);
  EXPECT_EQ(e["topics"]["hullpipe/camera_info"]["json_lines"], 2);
  int pngs = 0;
  for (const auto& f : std::filesystem::recursive_directory_iterator(out + "/maps"))
    pngs += f.path().extension() == ".png";
  EXPECT_EQ(pngs, maps_sent);
  std::ifstream lines(out + "/hullpipe_object_pixel_map.jsonl");
  int n = 0;
  for (std::string line; std::getline(lines, line); ++n) EXPECT_EQ(nlohmann::json::parse(line)["width"], 64);
  EXPECT_EQ(n, maps_sent);
  // echo: the same JSON lines on stdout (the log on stderr).
  const std::string echo_log = (dir_ / "echo.log").string();
  test::Process echo({test::BinDir() + "/hullpipe_record", "echo", set, "--topic", "hullpipe/object_pixel_map",
                      "--domain", std::to_string(test::UniqueDomain())}, echo_log);
  ASSERT_EQ(echo.Wait(60), 0) << test::ReadFile(echo_log);
  std::istringstream echoed(test::ReadFile(echo_log));
  int lines_echoed = 0;
  for (std::string line; std::getline(echoed, line);)
    if (!line.empty() && line[0] == '{')
      lines_echoed += nlohmann::json::parse(line)["topic"] == "hullpipe/object_pixel_map";
  EXPECT_EQ(lines_echoed, maps_sent);
  // The directory replays as one recording.
  const uint32_t d2 = test::UniqueDomain();
  dds::Participant p2(d2);
  dds::CdrReader cdr(p2, *dds::FindKnownType("hullpipe::msg::ObjectPixelMap"), dds::QosSpec{true, false, 64});
  auto replay = Start("hullpipe_replay", {set, "--wait-readers", "1", "--rate", "0", "--no-keyboard"}, d2);
  size_t got = 0;
  WaitFor([&] {
    got += cdr.TakeEach([](const std::vector<uint8_t>&, int64_t) {});
    return got >= size_t(maps_sent);
  }, 20);
  EXPECT_EQ(got, size_t(maps_sent)) << Log("hullpipe_replay");
  EXPECT_EQ(replay->Wait(30), 0) << Log("hullpipe_replay");

  // Exported onto a full disk (a file size limit of 2 KiB, SIGXFSZ ignored:
  // each write past it fails with EFBIG): exit 1 naming the first file that
  // could not be written (0-byte PNGs and export.json with exit 0 before).
  // MCAP only: SQLite's reader writes its 32-KiB -shm file, so under the
  // limit the recording does not open (exit 1 too, for another reason).
  if (Ext() == ".mcap") {
    const std::string full_log = (dir_ / "export_full.log").string();
    test::Process full(
        {"/bin/sh", "-c", "trap '' XFSZ; ulimit -f 2; exec \"$0\" \"$@\"", test::BinDir() + "/hullpipe_record",
         "export", set, "-o", (dir_ / "export_full").string(), "--domain", std::to_string(test::UniqueDomain())},
        full_log);
    EXPECT_EQ(full.Wait(60), 1) << test::ReadFile(full_log);
    EXPECT_NE(test::ReadFile(full_log).find("could not be written (a full disk?), the first"), std::string::npos)
        << test::ReadFile(full_log);
  }

  // A part missing: what the others hold is exported and replayed, the part is
  // named, and both exit 3 (they exited 0 while info said DAMAGED).
  const auto holed = dir_ / ("holed" + Ext());
  std::filesystem::create_directories(holed);
  const auto files = parts();
  ASSERT_GE(files.size(), 3u);
  for (size_t i = 0; i < files.size(); ++i)
    if (i != 1) std::filesystem::copy_file(files[i], holed / files[i].filename());
  const std::string holed_log = (dir_ / "export_holed.log").string();
  test::Process holed_export({test::BinDir() + "/hullpipe_record", "export", holed.string(), "-o",
                              (dir_ / "export_holed").string(), "--domain", std::to_string(test::UniqueDomain())},
                             holed_log);
  EXPECT_EQ(holed_export.Wait(60), 3) << test::ReadFile(holed_log);
  EXPECT_NE(test::ReadFile(holed_log).find("part 1 missing"), std::string::npos) << test::ReadFile(holed_log);
  auto holed_replay = Start("hullpipe_replay", {holed.string(), "--rate", "0", "--no-keyboard", "--linger", "0"},
                            test::UniqueDomain());
  EXPECT_EQ(holed_replay->Wait(30), 3) << Log("hullpipe_replay");
  EXPECT_NE(Log("hullpipe_replay").find("part 1 missing"), std::string::npos) << Log("hullpipe_replay");
}

// Snapshot mode: nothing is written until told; `hullpipe_cmd snapshot` and
// SIGUSR1 each write the last N seconds (with the calibration) to a new file.
TEST_P(RecordToolsOn, SnapshotsHoldTheLastSecondsWhenTold) {
  const std::string dir = (dir_ / ("snaps" + Ext())).string();
  auto recorder = Start("hullpipe_record", {"-o", dir, "--snapshot-seconds", "1"});
  // Maps at 30 Hz all along, so that the last second before each trigger holds
  // some however late the trigger arrives (a loaded machine took over a second
  // to start hullpipe_cmd after a fixed 2 s of maps: the window was empty).
  std::atomic<bool> stop{false};
  std::atomic<int> sent{0};
  std::thread publisher([&] { PublishMaps(domain_, 0, 30, [] { return true; }, &stop, &sent); });
  struct Join {
    std::atomic<bool>& stop;
    std::thread& t;
    ~Join() {
      stop = true;
      t.join();
    }
  } join{stop, publisher};
  WaitFor([&] { return sent >= 60; }, 30);  // 2 s of maps
  ASSERT_GE(sent.load(), 60);
  const std::string first = dir + "/snapshot_0001" + Ext(), second = dir + "/snapshot_0002" + Ext();
  EXPECT_FALSE(std::filesystem::exists(first)) << "written before it was told";
  const std::string cmd_log = (dir_ / "cmd.log").string();
  test::Process cmd({test::BinDir() + "/hullpipe_cmd", "snapshot", "--domain", std::to_string(domain_)}, cmd_log);
  ASSERT_EQ(cmd.Wait(30), 0) << test::ReadFile(cmd_log);
  WaitFor(
      [&] {
        return std::filesystem::exists(first) && Log("hullpipe_record").find("snapshot (command)") != std::string::npos;
      },
      20);
  ASSERT_TRUE(std::filesystem::exists(first)) << Log("hullpipe_record");
  recorder->Signal(SIGUSR1);
  WaitFor([&] { return Log("hullpipe_record").find("snapshot (SIGUSR1)") != std::string::npos; }, 20);
  EXPECT_TRUE(std::filesystem::exists(second)) << Log("hullpipe_record");
  stop = true;
  EXPECT_EQ(recorder->Stop(), 0) << Log("hullpipe_record");
  const RecordingReader r(first);
  const RecordingInfo info = r.Info();
  EXPECT_EQ(info.damage, "");
  EXPECT_EQ(info.meta.at("snapshot_trigger"), "command");
  const int64_t at = std::stoll(info.meta.at("snapshot_ns"));
  std::map<std::string, int64_t> counts;
  for (const auto& t : info.topics) counts[t.topic.name] = t.count;
  EXPECT_EQ(counts["hullpipe/camera_info"], 2);  // kept from before the window
  // The maps: only the last second before the trigger (each checked below),
  // some of them: at most a second and a frame of 30 Hz per camera, and where
  // the tests' time scale is relaxed (TSan slows the recorder) a backlog it
  // takes late, stamped inside the window: 10 frames a camera per unit of scale.
  EXPECT_GT(counts["hullpipe/object_pixel_map"], 0);
  EXPECT_LE(counts["hullpipe/object_pixel_map"], 2 * (31 + 10 * (test::TimeScale() - 1)));
  std::map<int64_t, std::string> names;
  for (const auto& t : r.topics()) names[t.id] = t.name;
  r.ForEach([&](const Sample& s) {
    if (names[s.topic_id] == "hullpipe/object_pixel_map") {
      EXPECT_GE(s.arrival_ns, at - 1'000'000'000);
    }
    return true;
  });
}

// A replay started paused sends nothing until stepped; `hullpipe_cmd step`
// releases samples, `resume` plays the rest.
TEST_P(RecordToolsOn, AReplayStartedPausedIsSteppedAndResumedFromTheDomain) {
  const std::string path = (dir_ / ("p" + Ext())).string();
  {
    auto recorder = Start("hullpipe_record", {"-o", path});
    PublishMaps(domain_, 20, 0, [] { return true; });
    EXPECT_EQ(recorder->Stop(), 0) << Log("hullpipe_record");
  }
  const uint32_t d2 = test::UniqueDomain();
  dds::Participant p2(d2);
  dds::CdrReader cdr(p2, *dds::FindKnownType("hullpipe::msg::ObjectPixelMap"), dds::QosSpec{true, false, 64});
  auto replay = Start("hullpipe_replay", {path, "--start-paused", "--wait-readers", "1", "--no-keyboard"}, d2);
  WaitFor([&] { return Log("hullpipe_replay").find("paused:") != std::string::npos; }, 20);
  ASSERT_NE(Log("hullpipe_replay").find("paused:"), std::string::npos) << Log("hullpipe_replay");
  size_t got = 0;
  auto take = [&] { got += cdr.TakeEach([](const std::vector<uint8_t>&, int64_t) {}); };
  auto send = [&](std::vector<std::string> args) {
    args.insert(args.begin(), test::BinDir() + "/hullpipe_cmd");
    args.insert(args.end(), {"--domain", std::to_string(d2)});
    const std::string log = (dir_ / ("cmd_" + args[1] + ".log")).string();
    test::Process c(args, log);
    EXPECT_EQ(c.Wait(30), 0) << test::ReadFile(log);
  };
  take();
  EXPECT_EQ(got, 0u) << "played while paused";
  send({"step", "5"});  // the two CameraInfo samples, then three maps
  WaitFor([&] {
    take();
    return got >= 3;
  }, 20);
  EXPECT_EQ(got, 3u) << Log("hullpipe_replay");  // (the positive control of the absence above)
  send({"resume"});
  WaitFor([&] {
    take();
    return got >= 40;
  }, 20);
  EXPECT_EQ(got, 40u) << Log("hullpipe_replay");
  EXPECT_EQ(replay->Wait(30), 0) << Log("hullpipe_replay");
}

TEST_P(RecordToolsOn, RecorderKilledBySigkillLeavesARecordingThatOpens) {
  const std::string path = (dir_ / ("k" + Ext())).string();
  dds::Participant p(domain_);
  dds::Writer<hullpipe_msg_ObjectPixelMap> maps(p);
  auto recorder = Start("hullpipe_record", {"-o", path, "--batch-ms", "50"});
  WaitFor([&] { return maps.MatchedReaders() > 0; }, 20);
  ASSERT_GT(maps.MatchedReaders(), 0u) << Log("hullpipe_record");
  const cv::Mat map(48, 64, CV_8UC1, cv::Scalar(0));
  uint64_t seq = 0;
  auto send = [&](int n) {
    for (int i = 0; i < n; ++i) {
      maps.Write(dds::MakeMapMessage({1, ++seq, NowNs(), 0}, 1, map).msg);
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  };
  send(100);
  // What the file shows while the recorder runs (read-only, as any reader
  // would): wait until every sample sent so far is committed, however slow the
  // recorder is (under ThreadSanitizer it lags by seconds).
  int64_t committed = 0;
  WaitFor([&] {
    try {
      committed = RecordingReader(path).Info().samples;
    } catch (const RecordingError&) {  // mid-write: looked at again
    }
    return committed >= int64_t(seq);
  }, 60);
  ASSERT_EQ(committed, int64_t(seq)) << Log("hullpipe_record");
  send(5);
  recorder.reset();  // SIGKILL, mid-stream: the last batch is not committed
  const RecordingReader rec(path);
  const auto info = rec.Info();
  // Every committed sample survives the kill.
  EXPECT_GE(info.samples, committed);
  EXPECT_LE(info.samples, int64_t(seq));
  EXPECT_TRUE(info.interrupted);
  // `repair` copies what the file and its log hold into a new recording, marked
  // interrupted; repairing into an existing file is refused.
  const std::string fixed = (dir_ / ("k_fixed" + Ext())).string();
  const std::string log = (dir_ / "repair.log").string();
  test::Process repair({test::BinDir() + "/hullpipe_record", "repair", path, "-o", fixed}, log);
  ASSERT_EQ(repair.Wait(30), 0) << test::ReadFile(log);
  const RecordingInfo repaired = RecordingReader(fixed).Info();
  EXPECT_GE(repaired.samples, info.samples);
  EXPECT_TRUE(repaired.interrupted);
  EXPECT_EQ(repaired.damage, "");
  test::Process again({test::BinDir() + "/hullpipe_record", "repair", path, "-o", fixed}, log);
  EXPECT_EQ(again.Wait(30), 1);
  EXPECT_NE(test::ReadFile(log).find("never overwritten"), std::string::npos) << test::ReadFile(log);
}

TEST_P(RecordToolsOn, ReplayingTwiceIntoSimNodeGivesIdenticalCollisionReports) {
  // Record a synthetic run: a sphere the default ball scene's ball hits.
  const std::string path = (dir_ / ("s" + Ext())).string();
  {
    auto recorder = Start("hullpipe_record", {"-o", path, "--exclude", "hullpipe/camera_image"});
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    // --max-lag 60: a loaded machine delays frames rather than skipping them, so
    // the recording holds all 50 framesets.
    auto capture = Start("capture_node", {"--synthetic", "--synthetic-scene", "sphere", "--frames", "50",
                                          "--wait-readers", "1", "--wait-timeout", "20", "--max-lag", "60"});
    ASSERT_EQ(capture->Wait(60), 0) << Log("capture_node");
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    ASSERT_EQ(recorder->Stop(), 0) << Log("hullpipe_record");
  }
  auto run = [&](const std::string& file) {
    const uint32_t d = test::UniqueDomain();
    dds::Participant p(d);
    dds::Reader<hullpipe_msg_CollisionReport> reports(p);
    // --every-frameset: every frameset stepped in order, however busy the machine
    // (without it sim_node takes the newest and, loaded, passes over some).
    auto sim = Start("sim_node", {"--every-frameset"}, d);
    // Half speed: the history (4 framesets) then spans 320 ms of a stalled sim_node.
    auto replay = Start("hullpipe_replay", {file, "--wait-readers", "1", "--rate", "0.5", "--no-keyboard"}, d);
    // Taken as they come (the topic keeps the last 16 per object).
    std::map<uint64_t, std::vector<Eigen::Vector3d>> out;  // frame -> collision points
    WaitFor([&] {
      reports.TakeEach([&](const hullpipe_msg_CollisionReport& m, const dds_sample_info_t&) {
        auto& pts = out[m.frame_seq];
        for (uint32_t i = 0; i < m.collision_points._length; ++i)
          pts.push_back(dds::FromMsg(m.collision_points._buffer[i]));
      });
      return out.size() >= 50;
    }, 40);
    EXPECT_EQ(replay->Wait(60), 0) << Log("hullpipe_replay");
    EXPECT_EQ(sim->Stop(), 0) << Log("sim_node");
    return out;
  };
  const auto a = run(path);
  const auto b = run(path);
  // Its twin in the other storage (hullpipe_record convert) replays into the
  // same reports, exactly.
  const std::string twin = (dir_ / (Ext() == ".mcap" ? "s_twin.hprec" : "s_twin.mcap")).string();
  {
    const std::string log = (dir_ / "convert.log").string();
    test::Process convert({test::BinDir() + "/hullpipe_record", "convert", path, "-o", twin}, log);
    ASSERT_EQ(convert.Wait(60), 0) << test::ReadFile(log);
  }
  const auto c = run(twin);
  // The per-node benchmark runs sim_node alone on the same recording.
  {
    const std::string log = (dir_ / "node_bench.log").string();
    test::Process bench({test::BinDir() + "/node_bench", "--node", "sim", "--recording", path, "--frames", "20",
                         "--json"},
                        log, {}, log + ".err");
    ASSERT_EQ(bench.Wait(120), 0) << test::ReadFile(log + ".err");
    const std::string out = test::ReadFile(log);
    EXPECT_TRUE(nlohmann::json::accept(out)) << "stdout must hold the JSON alone: " << out;
    EXPECT_NE(out.find("\"frames\":20"), std::string::npos) << out;
    EXPECT_NE(out.find("\"timeouts\":0"), std::string::npos) << out;
    EXPECT_NE(out.find("latency_ms_p99"), std::string::npos) << out;
  }
  ASSERT_EQ(a.size(), 50u);
  int colliding = 0;
  for (const auto& [f, pts] : a) colliding += !pts.empty();
  EXPECT_GT(colliding, 0);  // the ball did hit the hull
  ASSERT_EQ(a.size(), b.size());
  for (const auto& [f, pts] : a) {
    ASSERT_TRUE(b.count(f)) << f;
    EXPECT_EQ(pts, b.at(f)) << "frame " << f;  // exactly, not approximately
  }
  ASSERT_EQ(a.size(), c.size()) << twin;
  for (const auto& [f, pts] : a) {
    ASSERT_TRUE(c.count(f)) << f;
    EXPECT_EQ(pts, c.at(f)) << "frame " << f << " of the twin " << twin;
  }
}

// The per-node benchmark of a recon node on a head-mounted display's run
// (docs/hmd.md, "What it costs"): a stereo run recorded (two ViewPoses a
// frameset, one per eye), node_bench sends a frameset with both of its
// ViewPoses and counts it only when a HullView answered each; with --views
// first it sends the left eye's alone, the mono frame of the same view.
TEST_F(RecordTools, TheReconBenchAnswersBothEyesOfAStereoRecordingOrTheFirstAlone) {
  const std::string path = (dir_ / "stereo.hprec").string();
  {
    auto recorder = Start("hullpipe_record",
                          {"-o", path, "--include", "hullpipe/camera_info", "--include", "hullpipe/object_pixel_map",
                           "--include", "hullpipe/camera_image", "--include", "hullpipe/view_pose"});
    auto recon = Start("recon_node", {"--tile", "0/1", "--backend", "cpu", "--planes", "20"});
    auto render = Start("render_node", {"--stereo", "--width", "64", "--height", "48", "--tiles", "1", "--window",
                                        "off", "--out", (dir_ / "out").string(), "--max-in-flight", "1"});
    auto capture = Start("capture_node", {"--synthetic", "--frames", "12", "--fps", "10", "--wait-readers", "3",
                                          "--wait-timeout", "30", "--max-lag", "30"});
    ASSERT_EQ(capture->Wait(60), 0) << Log("capture_node");
    ASSERT_EQ(render->Wait(30), 0) << Log("render_node");
    EXPECT_EQ(recon->Stop(), 0) << Log("recon_node");
    ASSERT_EQ(recorder->Stop(), 0) << Log("hullpipe_record");
  }
  auto bench = [&](const std::string& views) {
    const std::string log = (dir_ / ("node_bench_" + views + ".log")).string();
    test::Process b({test::BinDir() + "/node_bench", "--node", "recon", "--recording", path, "--views", views,
                     "--threads", "1", "--json"},
                    log, {}, log + ".err");
    EXPECT_EQ(b.Wait(120), 0) << test::ReadFile(log + ".err");
    const std::string out = test::ReadFile(log);
    EXPECT_TRUE(nlohmann::json::accept(out)) << "stdout must hold the JSON alone: " << out;
    return nlohmann::json::accept(out) ? nlohmann::json::parse(out) : nlohmann::json::object();
  };
  const nlohmann::json both = bench("all"), first = bench("first");
  ASSERT_TRUE(both.contains("frames") && first.contains("frames")) << both.dump() << first.dump();
  // Every recorded frameset with its views answered: two HullViews each, or one.
  EXPECT_GE(both["frames"].get<int>(), 6) << both.dump();
  EXPECT_EQ(both["timeouts"].get<int>(), 0) << both.dump();
  EXPECT_EQ(both["view_poses_sent"].get<int>(), 2 * both["frames"].get<int>()) << both.dump();
  EXPECT_EQ(first["frames"], both["frames"]) << first.dump();
  EXPECT_EQ(first["timeouts"].get<int>(), 0) << first.dump();
  EXPECT_EQ(first["view_poses_sent"], first["frames"]) << first.dump();
  EXPECT_GT(both["cpu_ms_per_frameset"].get<double>(), 0) << both.dump();
}

// The README's replay into live nodes, with the whole recording: run A
// (capture, recon, render) is recorded with every topic; run B is a live recon
// and render fed by replaying that recording with --all-topics. The recorded
// ViewPose, HullView and NodeStats once mixed with run B's own (63 of 426
// frames composited, the recorded rows shown as live, no warning). Now run B's
// nodes ignore them, count them and say so, and composite the replayed frames
// from their own poses (the control that the replay reached them).
TEST_F(RecordTools, AWholeRecordingReplayedIntoALiveRunIsNotMixedIn) {
  const std::string path = (dir_ / "run_a.hprec").string();
  const auto out_a = dir_ / "out_a", out_b = dir_ / "out_b";
  auto render_args = [](const std::string& run, const std::filesystem::path& out) {
    return std::vector<std::string>{"--run-id", run, "--tiles", "1", "--window", "off", "--out", out.string()};
  };
  const std::vector<std::string> recon_args = {"--tile", "0/1", "--backend", "cpu", "--planes", "20"};
  auto with_run = [](std::vector<std::string> a, const std::string& run) {
    a.insert(a.end(), {"--run-id", run});
    return a;
  };
  {
    auto recorder = Start("hullpipe_record", {"-o", path});
    auto recon = Start("recon_node", with_run(recon_args, "a"));
    auto render = Start("render_node", render_args("a", out_a));
    // Maps are read by the recorder, recon and render: capture starts when all three are there.
    auto capture = Start("capture_node", {"--synthetic", "--frames", "30", "--fps", "10", "--run-id", "a",
                                          "--wait-readers", "3", "--wait-timeout", "30", "--max-lag", "30"});
    ASSERT_EQ(capture->Wait(60), 0) << Log("capture_node");
    ASSERT_EQ(render->Wait(30), 0) << Log("render_node");
    EXPECT_EQ(recon->Stop(), 0) << Log("recon_node");
    ASSERT_EQ(recorder->Stop(), 0) << Log("hullpipe_record");
  }
  const auto run_a = nlohmann::json::parse(test::ReadFile((out_a / "stats.json").string()));
  ASSERT_GT(run_a["frames_composited"].get<int>(), 0) << run_a.dump();

  const uint32_t d = test::UniqueDomain();
  auto recon = Start("recon_node", with_run(recon_args, "b"), d);
  auto render = Start("render_node", render_args("b", out_b), d);
  auto replay =
      Start("hullpipe_replay", {path, "--all-topics", "--wait-readers", "2", "--rate", "1", "--no-keyboard"}, d);
  EXPECT_EQ(replay->Wait(60), 0) << Log("hullpipe_replay");
  // The recorded capture's final report is another run's: render B ends when no
  // frameset came for its idle time-out (5 s).
  ASSERT_EQ(render->Wait(30), 0) << Log("render_node");
  EXPECT_EQ(recon->Stop(), 0) << Log("recon_node");
  const auto run_b = nlohmann::json::parse(test::ReadFile((out_b / "stats.json").string()));
  EXPECT_EQ(run_b["run_id"], "000000000000000b");
  EXPECT_GT(run_b["ignored_from_other_runs"]["HullView"].get<int>(), 0) << run_b.dump();
  EXPECT_GT(run_b["ignored_from_other_runs"]["NodeStats"].get<int>(), 0) << run_b.dump();
  EXPECT_FALSE(run_b["nodes"].contains("capture")) << "the recorded capture is not this run's: " << run_b.dump();
  EXPECT_TRUE(run_b["nodes"].contains("recon0")) << run_b.dump();
  // Run B composited the replayed frames from its own poses: at least half of
  // the framesets that reached it (latest wins on a busy machine).
  const int complete = run_b["framesets"]["render"]["complete"].get<int>();
  EXPECT_GT(complete, 0) << run_b.dump();
  EXPECT_GE(run_b["frames_composited"].get<int>(), complete / (2 * test::TimeScale())) << run_b.dump();
  EXPECT_NE(Log("recon_node").find("ignoring ViewPose samples of another run (run id 000000000000000a"),
            std::string::npos)
      << Log("recon_node");
  EXPECT_NE(Log("render_node").find("ignoring HullView samples"), std::string::npos) << Log("render_node");
  // The whole run's recording exported for Foxglove: the hull view as an image
  // and as a point cloud once per composited pose, valid against Foxglove's own
  // JSON Schemas (tests/js/read_mcap.mjs).
  const std::string fox = (dir_ / "fox").string(), fox_log = (dir_ / "fox.log").string();
  test::Process exp({test::BinDir() + "/hullpipe_record", "export", path, "-o", fox, "--foxglove", "--ros2",
                     "--no-media", "--no-jsonl", "--domain", std::to_string(test::UniqueDomain())},
                    fox_log);
  ASSERT_EQ(exp.Wait(120), 0) << test::ReadFile(fox_log);
  const std::string js = std::string(HULLPIPE_SOURCE_DIR) + "/tests/js", node_out = (dir_ / "fox.json").string();
  test::Process node({"/usr/bin/env", "node", js + "/read_mcap.mjs", fox + "/foxglove.mcap"}, node_out, {},
                     node_out + ".err");
  ASSERT_EQ(node.Wait(120), 0) << test::ReadFile(node_out + ".err");
  const auto fj = nlohmann::json::parse(test::ReadFile(node_out));
  EXPECT_EQ(fj["invalid"].size(), 0u) << fj["invalid"].dump();
  const auto& points = fj["channels"]["/foxglove/hull_points"];
  EXPECT_GT(points["decoded"].get<int>(), 0) << fj["channels"].dump();
  EXPECT_EQ(points["decoded"], fj["channels"]["/foxglove/hull_view"]["decoded"]);
  EXPECT_EQ(points["schema"], "foxglove.PointCloud");
  EXPECT_GT(points["first"]["data"].get<int>(), 0);  // (read_mcap.mjs gives the base64 length)
  // render_node's own composite, recorded from its CompositedView topic: one per
  // composited frame at most (best-effort: a loaded machine may lose one).
  const auto& composited = fj["channels"]["/foxglove/composited"];
  EXPECT_EQ(composited["schema"], "foxglove.CompressedImage");
  EXPECT_GT(composited["decoded"].get<int>(), 0) << fj["channels"].dump();
  EXPECT_LE(composited["decoded"].get<int>(), run_a["frames_composited"].get<int>());

  // The same run as a ROS 2 bag (export --ros2, docs/ros2.md): every channel's
  // ros2msg schema parsed and every message decoded by Foxglove's ROS 2 reader
  // (tests/js/read_ros2_mcap.mjs): the cameras, the view and its pose, the
  // hull's points (one cloud per hull view). (This run has no sim_node: the
  // markers are Ros2Export.TheRecordingAsARosbag2McapOpensInFoxglovesRos2Reader's.)
  const std::string ros_out = (dir_ / "ros2.json").string();
  test::Process ros({"/usr/bin/env", "node", js + "/read_ros2_mcap.mjs", fox + "/ros2.mcap"}, ros_out, {},
                    ros_out + ".err");
  ASSERT_EQ(ros.Wait(120), 0) << test::ReadFile(ros_out + ".err");
  const auto rj = nlohmann::json::parse(test::ReadFile(ros_out));
  EXPECT_EQ(rj["invalid"].size(), 0u) << rj["invalid"].dump();
  const auto& rc = rj["channels"];
  for (const char* topic : {"/tf_static", "/tf", "/hullpipe/cam1/camera_info", "/hullpipe/cam1/object_pixel_map",
                            "/hullpipe/view/compressed", "/hullpipe/hull_points"}) {
    ASSERT_TRUE(rc.contains(topic)) << topic << ": " << rc.dump(1);
    EXPECT_GT(rc[topic]["decoded"].get<int>(), 0) << topic;
    EXPECT_EQ(rc[topic]["decoded"], rc[topic]["count"]) << topic;
  }
  EXPECT_EQ(rc["/hullpipe/hull_points"]["decoded"], points["decoded"]);  // one cloud per whole hull view
  const auto& cloud = rj["first"]["/hullpipe/hull_points"];
  EXPECT_EQ(cloud["point_step"], 16);
  EXPECT_EQ(cloud["fields"].size(), 4u);
  EXPECT_GT(cloud["width"].get<int>(), 0);
}

}  // namespace
}  // namespace hullpipe

namespace hullpipe {
namespace {

// A camera image sent as a region (capture_node --image-region) exports in
// its whole image, black around the region, and its JSON line names the
// region. A region of a camera with no calibration yet, or one whose whole
// image is larger than its camera's calibration, is refused before that image
// is made: counted as not decoded, its line naming why, the export exit 3.
TEST_F(RecordTools, ExportShowsAnImageRegionInItsWholeImageAndRefusesUnboundedOnes) {
  const std::string path = (dir_ / "regions.mcap").string();
  const Camera cam = test::SphereViews(1, 64, 48, Eigen::Vector3d(0, 0, -1), 0.3)[0].camera;
  const cv::Mat bgr(48, 64, CV_8UC3, cv::Scalar(40, 160, 220));
  const cv::Rect part(16, 8, 32, 24);
  {
    dds::Participant p(domain_);
    WriterOptions o;
    o.storage = Storage::kMcap;
    RecordingWriter w(path, o);
    int64_t t_ns = 1'000'000'000;
    auto add = [&](const char* type, const void* msg) {
      const dds::KnownType& kt = *dds::FindKnownType(type);
      TopicInfo topic;
      topic.name = kt.topic_name, topic.type = kt.type_name, topic.keyed = kt.keyed;
      topic.reliable = kt.qos.reliable, topic.transient_local = kt.qos.transient_local, topic.depth = kt.qos.depth;
      topic.type_description = dds::IdlText();
      const int64_t id = w.AddTopic(topic);
      t_ns += 40'000'000;
      w.Append({id, t_ns, t_ns, dds::CdrWriter(p, kt, kt.qos, dds::CdrWriter::Scope::kDecodeOnly).Encode(msg)});
    };
    // Before camera 1's calibration: refused (the export cannot bound it).
    const auto early = dds::MakeImageMessage(uint32_t(cam.id), 1, 1000, bgr, 0, part);
    add("hullpipe::msg::CameraImage", &early.msg);
    const auto info = dds::CameraToMsg(cam, test::BigBox());
    add("hullpipe::msg::CameraInfo", &info);
    const auto whole = dds::MakeImageMessage(uint32_t(cam.id), 2, 2000, bgr, 0);
    add("hullpipe::msg::CameraImage", &whole.msg);
    const auto region = dds::MakeImageMessage(uint32_t(cam.id), 3, 3000, bgr, 0, part);
    add("hullpipe::msg::CameraImage", &region.msg);
    auto huge = dds::MakeImageMessage(uint32_t(cam.id), 4, 4000, bgr, 0, part);
    huge.msg.full_width = huge.msg.full_height = 16384;
    add("hullpipe::msg::CameraImage", &huge.msg);
  }
  const std::string out = (dir_ / "regions_export").string();
  const std::string log = (dir_ / "regions_export.log").string();
  test::Process exp({test::BinDir() + "/hullpipe_record", "export", path, "-o", out, "--domain",
                     std::to_string(test::UniqueDomain())}, log);
  EXPECT_EQ(exp.Wait(60), 3) << test::ReadFile(log);
  const auto e = nlohmann::json::parse(test::ReadFile(out + "/export.json"));
  const auto& images = e["topics"]["hullpipe/camera_image"];
  EXPECT_EQ(images["samples"], 4);
  EXPECT_EQ(images["undecodable"], 2);
  EXPECT_EQ(images["video_frames"], 2);
  std::ifstream lines(out + "/hullpipe_camera_image.jsonl");
  std::vector<nlohmann::json> j;
  for (std::string line; std::getline(lines, line);) j.push_back(nlohmann::json::parse(line));
  ASSERT_EQ(j.size(), 4u);
  EXPECT_NE(j[0].value("error", "").find("before its calibration"), std::string::npos) << j[0];
  EXPECT_FALSE(j[1].contains("x")) << "a whole image names no region: " << j[1];
  EXPECT_EQ(j[2]["x"], 16);
  EXPECT_EQ(j[2]["y"], 8);
  EXPECT_EQ(j[2]["width"], 32);
  EXPECT_EQ(j[2]["full_width"], 64);
  EXPECT_EQ(j[2]["full_height"], 48);
  EXPECT_FALSE(j[2].contains("error")) << j[2];
  EXPECT_NE(j[3].value("error", "").find("whole image 16384x16384 is larger than its calibration's 64x48"),
            std::string::npos) << j[3];
  // The video: the whole image, then the region in its whole image. MPEG-4 at
  // the writer's default quality blurs a flat colour's step by a few levels,
  // well under the 160 between the colour and black.
  cv::VideoCapture video(out + "/images_cam" + std::to_string(cam.id) + ".mp4");
  cv::Mat first, second;
  ASSERT_TRUE(video.read(first) && video.read(second));
  ASSERT_EQ(second.size(), cv::Size(64, 48)) << "the whole image, not the region";
  const cv::Rect inside(24, 16, 16, 8), left(0, 0, 8, 48);
  const double kTol = 40;
  EXPECT_LE(cv::norm(first(left), bgr(left), cv::NORM_INF), kTol) << "control: the whole image is coloured there";
  EXPECT_LE(cv::norm(second(inside), bgr(inside), cv::NORM_INF), kTol);
  EXPECT_LE(cv::norm(second(left), cv::NORM_INF), kTol) << "black around the region";
}

// The tools on bad recordings: one line naming the file, a non-zero exit, never
// a signal (each of these crashed or aborted before).
TEST_F(RecordTools, BadRecordingsEndInOneLineAndANonZeroExit) {
  auto cases = BadRecordings(dir_);
  // A bit-flipped recording (a seed whose flips land in the b-tree and the data).
  const std::string good = WriteRecording(dir_, "good.hprec", 200);
  std::string bytes = test::ReadFile(good);
  std::mt19937 rng(16);
  std::uniform_int_distribution<size_t> at(bytes.size() / 4, bytes.size() * 3 / 4);
  for (int k = 0; k < 8; ++k) bytes[at(rng)] ^= char(1 << (rng() % 8));
  const std::string flipped = (dir_ / "flipped.hprec").string();
  std::ofstream(flipped, std::ios::binary) << bytes;
  cases["bit flips"] = {flipped, "damaged"};
  int n = 0;
  for (const auto& [what, file] : cases) {
    for (const std::string exe : {"hullpipe_replay", "hullpipe_record", "export", "repair"}) {
      std::vector<std::string> args = {file.first, "--no-keyboard", "--linger", "0"};
      if (exe == "hullpipe_record") args = {"info", file.first};
      // A bad recording exported or repaired: one line naming it, non-zero, never
      // a crash (a repair that recovers no topic exits 3).
      const std::string out = (dir_ / ("out" + std::to_string(++n))).string();
      if (exe == "export") args = {"export", file.first, "-o", out, "--domain", std::to_string(domain_)};
      if (exe == "repair") args = {"repair", file.first, "-o", out + ".hprec"};
      if (what == "bit flips" && exe == "repair") continue;  // repairs (below)
      const std::string log_path = (dir_ / (exe + "_bad.log")).string();
      std::vector<std::string> argv = {test::BinDir() + "/" +
                                       (exe == "export" || exe == "repair" ? std::string("hullpipe_record") : exe)};
      argv.insert(argv.end(), args.begin(), args.end());
      test::Process run(argv, log_path);
      const int rc = run.Wait(30);
      const std::string log = test::ReadFile(log_path);
      EXPECT_TRUE(rc == 1 || rc == 3) << what << ", " << exe << ": " << launch::DescribeStatus(run.status()) << "\n"
                                      << log;
      EXPECT_NE(log.find(file.first), std::string::npos) << what << ", " << exe << ": " << log;
    }
  }
  // The bit-flipped file repairs: the rows whose CRC checks, none changed.
  const std::string fixed = (dir_ / "flipped_fixed.hprec").string();
  const std::string log = (dir_ / "flipped_repair.log").string();
  test::Process repair({test::BinDir() + "/hullpipe_record", "repair", flipped, "-o", fixed}, log);
  ASSERT_EQ(repair.Wait(30), 0) << test::ReadFile(log);
  const RecordingReader r(fixed);
  EXPECT_EQ(r.Info().damage, "");
  int64_t kept = 0;
  r.ForEach([&](const Sample& s) {
    const int k = int(s.arrival_ns / 1'000'000) - 1;
    for (size_t i = 0; i < s.data.size(); ++i)
      if (s.data[i] != uint8_t(k * 31 + int(i) * 7)) {
        ADD_FAILURE() << "a changed sample was repaired: " << k;
        break;
      }
    ++kept;
    return true;
  });
  EXPECT_GT(kept, 150);
  EXPECT_LE(kept, 200);
}

// echo and export of a damaged MCAP give what reads, name the damage in one
// line and exit 3, as info does (they exited 0 and said nothing for most cut
// files: the damage lay where no sample was read). A file cut only in its
// summary (all data there, no footer) is interrupted, not damaged, for info
// and for them alike; the sound file's runs name no damage (the controls).
TEST_F(RecordTools, EchoAndExportOfADamagedMcapNameTheDamage) {
  const std::string sound = WriteRecording(dir_, "sound.mcap", 200);
  const std::string bytes = test::ReadFile(sound);
  std::map<std::string, std::string> files = {{"sound", sound}};
  for (const size_t keep : {bytes.size() * 3 / 10, bytes.size() * 6 / 10, bytes.size() - 20}) {
    const std::string path = (dir_ / ("cut_" + std::to_string(keep) + ".mcap")).string();
    std::ofstream(path, std::ios::binary) << bytes.substr(0, keep);
    files["cut to " + std::to_string(keep) + " bytes"] = path;
  }
  int n = 0, damaged_files = 0;
  for (const auto& [what, path] : files) {
    // What info says of the file (the same check).
    const bool damaged = !RecordingReader(path).QuickCheck().empty();
    damaged_files += damaged;
    if (what == "sound") {
      EXPECT_FALSE(damaged);
    }
    for (const std::string cmd : {"echo", "export"}) {
      std::vector<std::string> argv = {test::BinDir() + "/hullpipe_record", cmd, path, "--domain",
                                       std::to_string(domain_)};
      if (cmd == "export") argv.insert(argv.end(), {"-o", (dir_ / ("x" + std::to_string(++n))).string()});
      const std::string out = (dir_ / ("echo" + std::to_string(++n) + ".out")).string();
      const std::string err = (dir_ / ("echo" + std::to_string(n) + ".err")).string();
      test::Process run(argv, out, {}, err);
      const int rc = run.Wait(60);
      const std::string log = test::ReadFile(err);
      if (damaged) {
        EXPECT_EQ(rc, 3) << what << ", " << cmd << ": " << log;
        EXPECT_NE(log.find(path + ": damaged: "), std::string::npos) << what << ", " << cmd << ": " << log;
      } else {
        // (The synthetic samples do not decode as maps: exit 3 for that, named.)
        EXPECT_EQ(log.find(": damaged: "), std::string::npos) << what << ", " << cmd << ": " << log;
      }
    }
  }
  EXPECT_EQ(damaged_files, 2) << "the cuts into the data are damage; the cut into the summary is not";
}

// SIGINT during a long gap between samples ends the replay within a second.
TEST_F(RecordTools, ReplayStopsWithinASecondOfSigintInAGap) {
  dds::Participant p(domain_);
  const dds::KnownType& map_type = *dds::FindKnownType("hullpipe::msg::ObjectPixelMap");
  dds::CdrReader cdr(p, map_type, dds::QosSpec{true, false, 8});
  // One real map, serialized (written here and taken back as CDR).
  std::vector<uint8_t> map_cdr;
  {
    dds::Writer<hullpipe_msg_ObjectPixelMap> maps(p);
    WaitFor([&] { return maps.MatchedReaders() > 0; }, 20);
    maps.Write(dds::MakeMapMessage({1, 1, NowNs(), 0}, 1, cv::Mat(48, 64, CV_8UC1, cv::Scalar(0))).msg);
    WaitFor([&] {
      cdr.TakeEach([&](const std::vector<uint8_t>& b, int64_t) { map_cdr = b; });
      return !map_cdr.empty();
    }, 20);
    ASSERT_FALSE(map_cdr.empty());
  }
  const std::string path = (dir_ / "gap.hprec").string();
  {
    RecordingWriter w(path);
    const int64_t t = w.AddTopic({0, "hullpipe/object_pixel_map", "hullpipe::msg::ObjectPixelMap", true, true,
                                  false, 4, ""});
    for (int k = 0; k < 3; ++k) {
      Sample s = MakeSample(t, (k + 1) * 1'000'000'000LL, 0);  // 1 s apart
      s.data = map_cdr;
      w.Append(s);
    }
  }
  // At rate 0.001 the gaps are 1000 s.
  auto replay = Start("hullpipe_replay", {path, "--rate", "0.001", "--no-keyboard", "--wait-readers", "1",
                                          "--settle", "0.2", "--linger", "0"});
  // In the gap: the first sample has arrived.
  int got = 0;
  WaitFor([&] {
    cdr.TakeEach([&](const std::vector<uint8_t>&, int64_t) { ++got; });
    return got > 0;
  }, 20);
  ASSERT_EQ(got, 1) << Log("hullpipe_replay");
  const double t0 = MonotonicSeconds();
  replay->Signal(SIGINT);
  EXPECT_EQ(replay->Wait(5), 0) << Log("hullpipe_replay");
  EXPECT_LT(MonotonicSeconds() - t0, 1.0 * test::TimeScale());
}

// Per topic name, every sample's bytes, sorted (arrival times differ between
// recorders; the bytes do not).
std::map<std::string, std::vector<std::vector<uint8_t>>> SamplesByTopic(const std::string& path) {
  const RecordingReader r(path);
  std::map<int64_t, std::string> names;
  for (const auto& t : r.topics()) names[t.id] = t.name;
  std::map<std::string, std::vector<std::vector<uint8_t>>> out;
  r.ForEach([&](const Sample& s) {
    out[names[s.topic_id]].push_back(s.data);
    return true;
  });
  for (auto& [name, v] : out) std::sort(v.begin(), v.end());
  return out;
}

// The rig's demo recorded as MCAP (uncompressed, zstd, lz4) beside an SQLite
// twin: readers nobody here wrote (tests/js/read_mcap.mjs: @mcap/core's stream
// reader with CRCs checked and its indexed reader; Foxglove's OMG IDL parser and
// CDR decoder) read every record and decode every message of every channel, the
// counts equal to `info`'s; the decoded CameraInfo is the rig's calibration; all
// four recordings hold the capture's samples byte for byte; `export --foxglove`
// adds viewable channels that Foxglove's own JSON Schemas accept.
TEST_F(RecordTools, TheRigsDemoAsMcapOpensInTheFieldsOwnReaders) {
  const std::string js = std::string(HULLPIPE_SOURCE_DIR) + "/tests/js";
  ASSERT_TRUE(std::filesystem::exists(js + "/node_modules/@mcap/core"))
      << "the npm readers are missing: scripts/setup.sh installs them (npm ci in tests/js)";
  const std::vector<std::pair<std::string, std::vector<std::string>>> recordings = {
      {"demo.hprec", {}},
      {"demo_none.mcap", {}},
      {"demo_zstd.mcap", {"--compression", "zstd"}},
      {"demo_lz4.mcap", {"--compression", "lz4"}}};
  const int frames = 6;
  const Rig rig = LoadRig(test::RigDir());
  const size_t cams = rig.cameras.size();
  {
    std::vector<std::unique_ptr<test::Process>> recorders;
    for (const auto& [name, extra] : recordings) {
      std::vector<std::string> args = {"-o", (dir_ / name).string(), "--batch-ms", "50"};
      args.insert(args.end(), extra.begin(), extra.end());
      recorders.push_back(Start("hullpipe_record", args));
    }
    // sim_node too, so the recording holds the balls' states (SceneUpdate below).
    auto sim = Start("sim_node", {});
    auto capture = Start("capture_node", {"--rig", test::RigDir(), "--frames", std::to_string(frames), "--wait-readers",
                                          std::to_string(recordings.size() + 1), "--wait-timeout", "30", "--max-lag",
                                          "60"});
    ASSERT_EQ(capture->Wait(120), 0) << Log("capture_node");
    // Every recorder has every map once the files say so (each readable while
    // written: SQLite's log, MCAP's chunks without a summary).
    auto maps_in = [&](const std::string& name) {
      try {
        for (const auto& t : RecordingReader((dir_ / name).string()).Info().topics)
          if (t.topic.name == "hullpipe/object_pixel_map") return t.count;
      } catch (const RecordingError&) {
      }
      return int64_t(0);
    };
    for (const auto& recording : recordings) {  // (clang 14's lambdas cannot capture a structured binding)
      const std::string& name = recording.first;
      WaitFor([&] { return maps_in(name) >= int64_t(frames * cams); }, 30);
      EXPECT_EQ(maps_in(name), int64_t(frames * cams)) << name << "\n" << Log("hullpipe_record");
    }
    // Every recorder has sim's first ball states too before all stop.
    auto states_in = [&](const std::string& name) {
      try {
        for (const auto& t : RecordingReader((dir_ / name).string()).Info().topics)
          if (t.topic.name == "hullpipe/object_state") return t.count;
      } catch (const RecordingError&) {
      }
      return int64_t(0);
    };
    for (const auto& recording : recordings) WaitFor([&] { return states_in(recording.first) > 0; }, 30);
    EXPECT_EQ(sim->Stop(), 0) << Log("sim_node");
    for (auto& r : recorders) EXPECT_EQ(r->Stop(), 0) << Log("hullpipe_record");
  }
  // The capture's topics byte for byte (sim's last states may reach one recorder
  // and not another as they stop).
  auto capture_topics = [](std::map<std::string, std::vector<std::vector<uint8_t>>> m) {
    for (auto it = m.begin(); it != m.end();)
      it = it->first == "hullpipe/camera_info" || it->first == "hullpipe/object_pixel_map" ||
                   it->first == "hullpipe/camera_image"
               ? std::next(it)
               : m.erase(it);
    return m;
  };
  const auto twin = capture_topics(SamplesByTopic((dir_ / "demo.hprec").string()));
  ASSERT_EQ(twin.at("hullpipe/camera_image").size(), frames * cams);
  for (const auto& [name, extra] : recordings) {
    if (name == "demo.hprec") continue;
    const std::string path = (dir_ / name).string();
    EXPECT_TRUE(capture_topics(SamplesByTopic(path)) == twin) << name << " holds other samples than its SQLite twin";
    const std::string info_out = (dir_ / (name + ".info.json")).string();
    test::Process info({test::BinDir() + "/hullpipe_record", "info", path, "--json"}, info_out, {}, info_out + ".err");
    ASSERT_EQ(info.Wait(60), 0) << test::ReadFile(info_out + ".err");
    const auto ij = nlohmann::json::parse(test::ReadFile(info_out));
    EXPECT_EQ(ij["storage"], "mcap");
    const std::string node_out = (dir_ / (name + ".node.json")).string();
    test::Process node({"/usr/bin/env", "node", js + "/read_mcap.mjs", path}, node_out, {}, node_out + ".err");
    ASSERT_EQ(node.Wait(120), 0) << test::ReadFile(node_out + ".err");
    const auto nj = nlohmann::json::parse(test::ReadFile(node_out));  // stdout alone
    EXPECT_EQ(nj["records"]["Message"].get<int64_t>(), ij["samples"].get<int64_t>()) << name;
    EXPECT_EQ(nj["statistics"]["messageCount"].get<int64_t>(), ij["samples"].get<int64_t>()) << name;
    EXPECT_EQ(nj["records"]["Header"], 1);
    EXPECT_EQ(nj["records"]["Footer"], 1);
    EXPECT_GT(nj["chunkIndexes"].get<int>(), 0);
    EXPECT_TRUE(nj["ordered"].get<bool>()) << "messages out of log-time order";
    EXPECT_EQ(nj["invalid"].size(), 0u) << nj["invalid"].dump();
    ASSERT_EQ(nj["channels"].size(), ij["topics"].size()) << name;
    for (const auto& t : ij["topics"]) {
      const auto& c = nj["channels"][t["name"].get<std::string>()];
      EXPECT_EQ(c["count"], t["count"]) << name << " " << t["name"];
      EXPECT_EQ(c["decoded"], t["count"]) << name << " " << t["name"] << ": not every message decoded";
      EXPECT_EQ(c["schema"], t["type"]);
      EXPECT_EQ(c["schemaEncoding"], "omgidl");
      EXPECT_EQ(c["messageEncoding"], "cdr");
      EXPECT_NE(
          c["qos"].get<std::string>().find(t["reliable"].get<bool>() ? "reliability: true" : "reliability: false"),
          std::string::npos);
    }
    // The decoded calibration is the rig's, to the last bit printed (%.17g).
    ASSERT_EQ(nj["cameraInfo"].size(), cams) << name;
    for (const auto& ci : nj["cameraInfo"]) {
      const auto cam = std::find_if(rig.cameras.begin(), rig.cameras.end(),
                                    [&](const RigCamera& c) { return c.camera.id == ci["camera_id"].get<int>(); });
      ASSERT_NE(cam, rig.cameras.end()) << ci.dump();
      EXPECT_EQ(ci["width"], cam->camera.width);
      EXPECT_EQ(ci["height"], cam->camera.height);
      const Eigen::Matrix3d K = cam->camera.K();
      for (int i = 0; i < 9; ++i) EXPECT_DOUBLE_EQ(ci["K"][i].get<double>(), K(i / 3, i % 3)) << i;
      const Eigen::Vector3d t = cam->camera.cam_from_world.translation;
      for (int i = 0; i < 3; ++i)
        EXPECT_DOUBLE_EQ(ci["cam_from_world_translation"][i].get<double>(), t(i)) << i;
    }
  }
  // `export --foxglove`: the recording's channels plus viewable ones in
  // Foxglove's schemas, each message valid against Foxglove's own JSON Schema
  // (checked by ajv in read_mcap.mjs), the images real JPEG and PNG.
  const std::string out = (dir_ / "fox").string();
  const std::string export_log = (dir_ / "fox_export.log").string();
  test::Process exp({test::BinDir() + "/hullpipe_record", "export", (dir_ / "demo_zstd.mcap").string(), "-o", out,
                     "--foxglove", "--no-media", "--no-jsonl", "--domain", std::to_string(test::UniqueDomain())},
                    export_log);
  ASSERT_EQ(exp.Wait(120), 0) << test::ReadFile(export_log);
  const std::string fox_out = (dir_ / "fox.node.json").string();
  test::Process node({"/usr/bin/env", "node", js + "/read_mcap.mjs", out + "/foxglove.mcap"}, fox_out, {},
                     fox_out + ".err");
  ASSERT_EQ(node.Wait(120), 0) << test::ReadFile(fox_out + ".err");
  const auto fj = nlohmann::json::parse(test::ReadFile(fox_out));
  EXPECT_EQ(fj["invalid"].size(), 0u) << fj["invalid"].dump();
  const auto recorded = RecordingReader((dir_ / "demo_zstd.mcap").string()).Info();
  std::map<std::string, int64_t> counts;
  for (const auto& t : recorded.topics) counts[t.topic.name] = t.count;
  const auto& ch = fj["channels"];
  for (const auto& [name, n] : counts) {
    if (n == 0) continue;  // a topic discovered, never written: no channel in the export
    ASSERT_TRUE(ch.contains(name)) << name;
    EXPECT_EQ(ch[name]["count"], n) << name;  // the raw channels, untouched
    EXPECT_EQ(ch[name]["decoded"], n) << name;
  }
  for (const auto& c : rig.cameras) {
    const std::string cam = "/foxglove/cam" + std::to_string(c.camera.id);
    EXPECT_EQ(ch[cam + "/image"]["decoded"], frames) << cam;
    EXPECT_EQ(ch[cam + "/image"]["schema"], "foxglove.CompressedImage");
    EXPECT_EQ(ch[cam + "/object_pixel_map"]["decoded"], frames) << cam;
    EXPECT_EQ(ch[cam + "/calibration"]["decoded"], 1) << cam;
    // OpenCV's pixel centres (integers) in Foxglove's K, hullpipe's at +0.5.
    const auto& K = ch[cam + "/calibration"]["first"]["K"];
    EXPECT_DOUBLE_EQ(K[2].get<double>(), c.camera.K()(0, 2) - 0.5);
    EXPECT_EQ(ch[cam + "/calibration"]["messageEncoding"], "json");
  }
  EXPECT_EQ(ch["/foxglove/tf"]["decoded"], int64_t(cams));
  // One scene update per ball state, collision report and mesh; a CAD model's
  // part once, then when its pose or contact changes (at most once a state).
  const int64_t scene = counts["hullpipe/object_state"] + counts["hullpipe/collision_report"] +
                        counts["hullpipe/virtual_mesh"];
  EXPECT_GE(ch["/foxglove/scene"]["decoded"].get<int64_t>(), scene);
  EXPECT_LE(ch["/foxglove/scene"]["decoded"].get<int64_t>(),
            scene + counts["hullpipe/model_part"] * std::max<int64_t>(1, counts["hullpipe/model_state"]));
  if (counts["hullpipe/model_state"] == 0) {
    EXPECT_EQ(ch["/foxglove/scene"]["decoded"].get<int64_t>(), scene);
  }
  EXPECT_EQ(ch["/foxglove/node_stats"]["decoded"], counts["hullpipe/node_stats"]);
}

}  // namespace
}  // namespace hullpipe
