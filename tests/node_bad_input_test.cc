// Bad input from outside must never crash a node: each test starts a real node
// process on its own DDS domain (loopback only), feeds it malformed samples or
// broken files, checks it logged and counted them, that it still works on good
// input, and that it stops cleanly on SIGINT.
#include <signal.h>

#include <fstream>
#include <regex>

#include <gtest/gtest.h>
#include <opencv2/videoio.hpp>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/dds.h"
#include "hullpipe/dds/topics.h"
#include "test_util.h"

namespace hullpipe {
namespace {

using namespace hullpipe::dds;

class NodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::TempDir("node");
    config_ = test::WriteLoopbackConfig(dir_);
    setenv("CYCLONEDDS_URI", ("file://" + config_).c_str(), 1);
    domain_ = test::UniqueDomain();
    participant_ = std::make_unique<Participant>(domain_);
  }
  std::unique_ptr<test::Process> Start(const std::string& exe, std::vector<std::string> args) {
    log_ = (dir_ / (exe + ".log")).string();
    return test::StartExe(exe, std::move(args), domain_, config_, log_);
  }
  /// Waits until an endpoint of ours has matched n of the node's (MatchedReaders
  /// for our writers, MatchedWriters for our readers).
  template <typename E>
  void WaitMatched(const E& e, uint32_t n) {
    auto matched = [&] {
      if constexpr (requires { e.MatchedReaders(); }) {
        return e.MatchedReaders();
      } else {
        return e.MatchedWriters();
      }
    };
    const double end = MonotonicSeconds() + 20;
    while (matched() < n && MonotonicSeconds() < end) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    ASSERT_GE(matched(), n) << "node did not appear on the domain; log:\n" << test::ReadFile(log_);
    // Matching is seen on each side at its own moment: the node's reader may
    // not have matched our writer yet, so a volatile sample written now can be
    // lost. Each test therefore repeats its first samples until the node
    // answers (a handshake), and commands are transient-local.
  }
  /// Takes samples of `r` for wait_s seconds, calling f on each; returns how many.
  template <typename T, typename F>
  static int Drain(const Reader<T>& r, double wait_s, F f) {
    int n = 0;
    const double end = MonotonicSeconds() + wait_s;
    while (MonotonicSeconds() < end) {
      n += int(r.TakeEach([&](const T& m, const dds_sample_info_t&) { f(m); }));
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return n;
  }
  /// Newest NodeStats of `name` once its rejected count reaches `min_rejected` (or timeout).
  hullpipe_msg_NodeStats WaitStats(Reader<hullpipe_msg_NodeStats>& r, const std::string& name, uint64_t min_rejected,
                                    double timeout_s = 10) {
    hullpipe_msg_NodeStats last{};
    const double end = MonotonicSeconds() + timeout_s;
    while (MonotonicSeconds() < end) {
      r.TakeEach([&](const hullpipe_msg_NodeStats& m, const dds_sample_info_t&) {
        if (m.node_name && name == m.node_name) {
          last = m;
          last.node_name = nullptr;
          last.stages = {};
        }
      });
      if (last.rejected >= min_rejected) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return last;
  }
  /// One frameset of `views` (their calibration, maps and `image`, numbered seq)
  /// written now: what the mid-work tests feed a node until it works.
  static void WriteFrameset(const Writer<hullpipe_msg_CameraInfo>& info,
                            const Writer<hullpipe_msg_ObjectPixelMap>& maps,
                            const Writer<hullpipe_msg_CameraImage>& images, const std::vector<CameraMap>& views,
                            const cv::Mat& image, uint64_t seq) {
    for (const auto& v : views) info.Write(CameraToMsg(v.camera, test::BigBox()));
    const int64_t t = NowNs();
    for (const auto& v : views) {
      maps.Write(MakeMapMessage({uint32_t(v.camera.id), seq, t, double(seq) / 25}, 2, v.map).msg);
      images.Write(MakeImageMessage(uint32_t(v.camera.id), seq, t, image, 0).msg);
    }
  }
  /// SIGINT to `node`, seen mid-work: it must exit 0 within a second (README,
  /// "Engineering rules") and log that the work was interrupted (the positive
  /// control that the signal came mid-work, not between frames).
  void ExpectStopsWithinASecondOfSigintMidWork(test::Process& node, const std::string& exe) {
    ASSERT_TRUE(node.Running()) << exe << ":\n" << test::ReadFile(log_);
    node.Signal(SIGINT);
    const double t0 = MonotonicSeconds();
    const int rc = node.Wait(10);
    const double took = MonotonicSeconds() - t0;
    const std::string log = test::ReadFile(log_);
    EXPECT_EQ(rc, 0) << exe << "\n" << log;
    EXPECT_LT(took, 1.0 * test::TimeScale()) << exe << " took " << took << " s to stop\n" << log;
    EXPECT_NE(log.find("interrupted by a stop request; stopping"), std::string::npos) << exe << "\n" << log;
  }

  std::filesystem::path dir_;
  std::string config_, log_;
  uint32_t domain_ = 0;
  std::unique_ptr<Participant> participant_;
};

const Eigen::Vector3d kCentre(0, 0, -1);

TEST_F(NodeTest, ReconNodeSurvivesMalformedSamplesAndAStoppedCamera) {
  auto node = Start("recon_node", {"--tile", "0/1", "--planes", "20", "--backend", "cpu"});
  Writer<hullpipe_msg_CameraInfo> info(*participant_);
  Writer<hullpipe_msg_ObjectPixelMap> maps(*participant_);
  Writer<hullpipe_msg_CameraImage> images(*participant_);
  Writer<hullpipe_msg_ViewPose> poses(*participant_);
  Reader<hullpipe_msg_HullView> tiles(*participant_);
  Reader<hullpipe_msg_NodeStats> stats(*participant_);
  WaitMatched(info, 1);
  WaitMatched(images, 1);
  WaitMatched(poses, 1);
  WaitMatched(maps, 1);
  WaitMatched(tiles, 1);
  WaitMatched(stats, 1);
  const auto views = test::SphereViews(2, 64, 48, kCentre, 0.3);
  for (const auto& v : views) info.Write(CameraToMsg(v.camera, test::BigBox()));
  const cv::Mat img(48, 64, CV_8UC3, cv::Scalar(50, 60, 70));
  const NovelView view =
      NovelView::FromFov(40, 30, 1.0, LookAt(kCentre + Eigen::Vector3d(2, 0, -0.5), kCentre, {0, 0, -1}));

  auto send_frame = [&](uint64_t seq, bool both) {
    const int64_t t = NowNs();  // the cameras' frames of one instant: one capture time
    for (size_t c = 0; c < (both ? 2u : 1u); ++c) {
      const uint32_t id = uint32_t(views[c].camera.id);
      maps.Write(MakeMapMessage({id, seq, t, double(seq) / 25}, 2, views[c].map).msg);
      images.Write(MakeImageMessage(id, seq, t, img, 0).msg);
    }
    poses.Write(ViewToMsg(view, seq, seq, NowNs()));
  };
  auto count_tiles = [&](double wait_s) {
    return Drain(tiles, wait_s, [](const hullpipe_msg_HullView& m) { EXPECT_EQ(m.width * m.height, m.depth._length); });
  };
  // Handshake: good frames until a tile comes back, so every path is live
  // (volatile readers drop what was written before they synchronised).
  uint64_t seq = 100;
  for (int tries = 0; tries < 50 && count_tiles(0.2) == 0; ++tries) send_frame(++seq, true);
  ASSERT_GT(seq, 100u);
  count_tiles(0.5);

  // Malformed: a size other than the calibration's (refused before decoding),
  // runs that do not sum to the size, an unknown encoding, an image of the wrong
  // length, a pose with NaN.
  auto bad_map = MakeMapMessage({1, seq + 1, NowNs(), 0}, 2, views[0].map);
  bad_map.msg.height = 47;
  maps.Write(bad_map.msg);
  bad_map.msg.height = 48;
  bad_map.msg.runs._length -= 1;
  maps.Write(bad_map.msg);
  bad_map.msg.runs._length += 1;
  bad_map.msg.encoding = 7;
  maps.Write(bad_map.msg);
  auto bad_img = MakeImageMessage(1, seq + 1, NowNs(), img, 0);
  bad_img.msg.data._length -= 5;
  images.Write(bad_img.msg);
  auto bad_pose = ViewToMsg(view, seq + 1, seq + 1, NowNs());
  bad_pose.fx = std::nan("");
  poses.Write(bad_pose);
  // A camera id that has no CameraInfo: parked with its frame, rejected when the
  // frame is evicted (checked at the end, after more frames pushed it out).
  maps.Write(MakeMapMessage({99, seq + 2, NowNs(), 0}, 2, views[0].map).msg);

  // All four were refused and counted (checked before more traffic: keep-last
  // histories would let newer samples replace unread ones, by design).
  EXPECT_GE(WaitStats(stats, "recon0", 4).rejected, 4u) << test::ReadFile(log_);
  // A burst of frames: latest wins, so at least the newest is rendered.
  for (int k = 0; k < 5; ++k) send_frame(++seq, true);
  EXPECT_GE(count_tiles(3.0), 1) << test::ReadFile(log_);
  // Camera 2 stops sending: no tile can be made, the node waits and keeps running.
  for (int k = 0; k < 6; ++k) send_frame(++seq, false);
  EXPECT_EQ(count_tiles(2.0), 0);
  EXPECT_TRUE(node->Running());
  // It comes back: tiles again.
  send_frame(++seq, true);
  EXPECT_GE(count_tiles(3.0), 1) << test::ReadFile(log_);

  const auto st = WaitStats(stats, "recon0", 5);
  EXPECT_GE(st.rejected, 5u) << "camera 99 was not counted:\n" << test::ReadFile(log_);
  EXPECT_GE(st.dropped, 1u);  // the poses of the incomplete frames
  EXPECT_EQ(node->Stop(), 0) << test::ReadFile(log_);
  const std::string log = test::ReadFile(log_);
  EXPECT_NE(log.find("rejected: map of camera 1 is 64x47, calibration says 64x48"), std::string::npos) << log;
  EXPECT_NE(log.find("rejected: ObjectPixelMap of camera 1: object-pixel map runs sum to"), std::string::npos) << log;
}

TEST_F(NodeTest, SimNodeRejectsBadMapsAndKeepsSimulating) {
  auto node = Start("sim_node", {});
  Writer<hullpipe_msg_CameraInfo> info(*participant_);
  Writer<hullpipe_msg_ObjectPixelMap> maps(*participant_);
  Reader<hullpipe_msg_VirtualObjectState> states(*participant_);
  Reader<hullpipe_msg_NodeStats> stats(*participant_);
  WaitMatched(info, 1);
  WaitMatched(maps, 1);
  WaitMatched(states, 1);
  WaitMatched(stats, 1);
  const auto views = test::SphereViews(2, 64, 48, kCentre, 0.3);
  for (const auto& v : views) info.Write(CameraToMsg(v.camera, test::BigBox()));
  auto send = [&](uint64_t seq) {
    for (const auto& v : views)
      maps.Write(MakeMapMessage({uint32_t(v.camera.id), seq, NowNs(), double(seq) / 25}, 2, v.map).msg);
  };
  auto take_states = [&](double wait_s) {
    return Drain(states, wait_s,
                 [](const hullpipe_msg_VirtualObjectState& m) { EXPECT_TRUE(std::isfinite(m.position.x)); });
  };
  // Handshake: good framesets until the first state comes back.
  uint64_t seq = 1;
  for (int tries = 0; tries < 50 && take_states(0.2) == 0; ++tries) send(++seq);
  auto bad = MakeMapMessage({1, ++seq, NowNs(), 0}, 2, views[0].map);
  bad.msg.runs._length = 1;
  maps.Write(bad.msg);
  // It keeps simulating: a state per frameset goes on coming (framesets sent
  // until three states are back, or 20 s: slow under the sanitizers).
  int got = 0;
  const double end = MonotonicSeconds() + 20;
  while (got < 3 && MonotonicSeconds() < end) {
    send(++seq);
    got += take_states(0.3);  // one step per frameset
  }
  EXPECT_GE(got, 3);
  EXPECT_GE(WaitStats(stats, "sim", 1).rejected, 1u);
  EXPECT_EQ(node->Stop(), 0) << test::ReadFile(log_);
}

TEST_F(NodeTest, SimNodeChangesThePayloadSpacingWhileRunning) {
  auto node = Start("sim_node", {"--scene", std::string(HULLPIPE_SOURCE_DIR) + "/scenes/payload.yaml"});
  const std::string sim_log = log_;
  Writer<hullpipe_msg_CameraInfo> info(*participant_);
  Writer<hullpipe_msg_ObjectPixelMap> maps(*participant_);
  Writer<hullpipe_msg_SceneCommand> commands(*participant_);
  Reader<hullpipe_msg_VirtualMesh> meshes(*participant_);
  Reader<hullpipe_msg_NodeStats> stats(*participant_);
  WaitMatched(info, 1);
  WaitMatched(maps, 1);
  WaitMatched(commands, 1);
  WaitMatched(meshes, 1);
  const auto views = test::SphereViews(2, 64, 48, kCentre, 0.3);
  for (const auto& v : views) info.Write(CameraToMsg(v.camera, test::BigBox()));
  uint64_t seq = 1;
  // payload A's (object 301) near face along y, from the newest mesh.
  auto payload_a_min_y = [&](double wait_s) {
    double y = std::nan("");
    const double end = MonotonicSeconds() + wait_s;
    while (MonotonicSeconds() < end) {
      ++seq;
      for (const auto& v : views)
        maps.Write(MakeMapMessage({uint32_t(v.camera.id), seq, NowNs(), double(seq) / 25}, 2, v.map).msg);
      Drain(meshes, 0.2, [&](const hullpipe_msg_VirtualMesh& m) {
        if (m.object_id != 301) return;
        const VirtualMeshSample s = VirtualMeshFromMsg(m);
        y = 1e9;
        for (const auto& p : s.draw.vertices) y = std::min(y, p.y());
      });
      if (!std::isnan(y)) break;
    }
    return y;
  };
  const double y14 = payload_a_min_y(10);
  ASSERT_FALSE(std::isnan(y14)) << test::ReadFile(sim_log);
  // The command tool, as a user runs it.
  auto cmd = Start("hullpipe_cmd", {"set-spacing", "0.25"});
  EXPECT_EQ(cmd->Wait(20), 0) << test::ReadFile(log_);
  double y25 = y14;
  for (int k = 0; k < 20 && std::abs(y25 - y14) < 0.05; ++k) y25 = payload_a_min_y(2);
  EXPECT_NEAR(y25 - y14, 0.11, 1e-5);  // 25 cm instead of 14 (floats on the wire)
  // A bad command is counted as rejected and changes nothing.
  hullpipe_msg_SceneCommand bad{};
  bad.command_seq = 2;
  bad.command = hullpipe_msg_SCENE_COMMAND_SET_SPACING;
  bad.value = -3;
  commands.Write(bad);
  EXPECT_GE(WaitStats(stats, "sim", 1).rejected, 1u);
  EXPECT_NEAR(payload_a_min_y(2) - y14, 0.11, 1e-5);
  log_ = sim_log;
  EXPECT_EQ(node->Stop(), 0) << test::ReadFile(log_);
}

TEST_F(NodeTest, RenderNodeRejectsTilesOfTheWrongSize) {
  auto node = Start("render_node", {"--out", (dir_ / "out").string(), "--idle-timeout", "60"});
  Writer<hullpipe_msg_HullView> tiles(*participant_);
  Reader<hullpipe_msg_NodeStats> stats(*participant_);
  WaitMatched(tiles, 1);
  WaitMatched(stats, 1);
  HullTile t;
  t.rect = {0, 0, 8, 8};
  t.depth = cv::Mat(8, 8, CV_32FC1, cv::Scalar(1));
  t.colour = cv::Mat(8, 8, CV_8UC3);
  auto s = MakeHullViewMessage(t, 1);
  s.msg.depth._length = 10;
  // Repeated until render counts it (its reader may match our writer late).
  uint64_t rejected = 0;
  for (const double end = MonotonicSeconds() + 20; rejected == 0 && MonotonicSeconds() < end;) {
    tiles.Write(s.msg);
    rejected = WaitStats(stats, "render", 1, 0.6).rejected;
  }
  EXPECT_GE(rejected, 1u) << test::ReadFile(log_);
  EXPECT_TRUE(node->Running());
  EXPECT_EQ(node->Stop(), 0) << test::ReadFile(log_);
}

// `set-spacing nan` once printed "sent" and exited 0 (NaN passes every range
// check by comparison): refused at once, one line naming the subcommand.
TEST_F(NodeTest, CmdRefusesANonFiniteSpacing) {
  for (const char* bad : {"nan", "inf", "-1"}) {
    auto cmd = Start("hullpipe_cmd", {"set-spacing", bad, "--timeout", "30"});
    EXPECT_EQ(cmd->Wait(10), 1) << bad << ": " << test::ReadFile(log_);
    EXPECT_NE(test::ReadFile(log_).find("set-spacing"), std::string::npos) << test::ReadFile(log_);
  }
}

// Flags out of their bounds end the node at once with one line naming the flag
// (exit 1 from the options' Check, 105 from CLI11's validators), never a run
// that composites nothing with exit 0. Positive control: render with in-bounds
// values reaches its loop and runs until stopped.
TEST_F(NodeTest, FlagsOutOfBoundsEndInOneLineNamingTheFlag) {
  struct Case {
    const char* exe;
    std::vector<std::string> args;
    const char* named;
  };
  const std::vector<Case> cases = {
      {"render_node", {"--tiles", "0"}, "--tiles"},
      {"render_node", {"--width", "0"}, "--width"},
      {"render_node", {"--hfov", "0"}, "--hfov"},
      {"render_node", {"--up", "0,0,0"}, "--up"},
      {"render_node", {"--video-fps", "nan"}, "--video-fps"},
      {"render_node", {"--png-every", "-1"}, "--png-every"},
      {"render_node", {"--log-level", "nonsense"}, "--log-level"},
      {"capture_node", {"--synthetic", "--max-lag", "nan"}, "--max-lag"},
      {"capture_node", {"--synthetic", "--wait-timeout", "inf"}, "--wait-timeout"},
      {"capture_node", {"--synthetic", "--fps", "-5"}, "--fps"},
      {"capture_node", {"--synthetic", "--synthetic-k1", "nan"}, "--synthetic-k1"},
      {"recon_node", {"--planes", "100000"}, "--planes"},
      {"recon_node", {"--tile", "3/2"}, "--tile"},
      {"sim_node", {"--skew-tolerance", "-1"}, "--skew-tolerance"},
  };
  for (const auto& c : cases) {
    std::vector<std::string> args = c.args;
    if (std::string(c.exe) == "render_node") args.insert(args.end(), {"--out", (dir_ / "render_out").string()});
    auto node = Start(c.exe, args);
    const int rc = node->Wait(20);
    const std::string log = test::ReadFile(log_);
    EXPECT_TRUE(rc == 1 || rc == 105) << c.exe << " " << c.args[0] << ": exit " << rc << "\n" << log;
    EXPECT_NE(log.find(c.named), std::string::npos) << c.exe << ": the flag is not named:\n" << log;
  }
  // Positive control: in-bounds values run until stopped.
  auto render = Start("render_node", {"--tiles", "1", "--width", "64", "--height", "48", "--window", "off", "--out",
                                      (dir_ / "render_ok").string()});
  // In its loop: render logs its progress line there once a second.
  for (const double end = MonotonicSeconds() + 20;
       test::ReadFile(log_).find("composited 0") == std::string::npos && MonotonicSeconds() < end;)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_NE(test::ReadFile(log_).find("composited 0"), std::string::npos) << test::ReadFile(log_);
  EXPECT_TRUE(render->Running()) << "still running:\n" << test::ReadFile(log_);
  EXPECT_EQ(render->Stop(), 0) << test::ReadFile(log_);
}

// Every node stops within a second of SIGINT while it waits: capture for its
// map readers (an hour's --wait-timeout), recon, sim and render for their first
// frameset. Each is seen in that state first (the line it logs there, and still
// running): the positive control that the signal, not an end, stopped it.
TEST_F(NodeTest, EveryNodeStopsWithinASecondOfSigintWhileWaiting) {
  struct Case {
    const char* exe;
    std::vector<std::string> args;
    const char* waiting_line;  // logged once in the waiting state
  };
  const std::vector<Case> cases = {
      {"capture_node", {"--synthetic", "--wait-readers", "4", "--wait-timeout", "3600"}, "camera(s) of"},
      {"recon_node", {"--tile", "0/1"}, "backend"},
      {"sim_node", {}, "ball(s)"},
      {"render_node", {"--window", "off", "--out", (dir_ / "render_wait").string()}, "composited 0"},
  };
  for (const auto& c : cases) {
    auto node = Start(c.exe, c.args);
    const double deadline = MonotonicSeconds() + 20;
    while (test::ReadFile(log_).find(c.waiting_line) == std::string::npos && MonotonicSeconds() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    ASSERT_NE(test::ReadFile(log_).find(c.waiting_line), std::string::npos) << c.exe << ":\n" << test::ReadFile(log_);
    ASSERT_TRUE(node->Running()) << c.exe << " is waiting:\n" << test::ReadFile(log_);
    node->Signal(SIGINT);
    const double t0 = MonotonicSeconds();
    const int rc = node->Wait(5);
    const double took = MonotonicSeconds() - t0;
    EXPECT_EQ(rc, 0) << c.exe << "\n" << test::ReadFile(log_);
    EXPECT_LT(took, 1.0 * test::TimeScale()) << c.exe << " took " << took << " s to stop\n" << test::ReadFile(log_);
  }
}

// Mid-work: recon_node in the sweep of the largest view it accepts (8192x8192,
// 4096 planes: over 10 s of work) and sim_node in the step of the heaviest
// scene (a 100,000-vertex cloth at 200 iterations and 1e-4 s substeps:
// minutes). Each is seen in that state first by its debug line, and must log
// that the work was interrupted (the positive control that the signal came
// mid-work, not between frames) and exit 0 within a second.
TEST_F(NodeTest, ReconAndSimStopWithinASecondOfSigintMidWork) {
  const auto views = test::SphereViews(2, 64, 48, kCentre, 0.3);
  const cv::Mat img(48, 64, CV_8UC3, cv::Scalar(50, 60, 70));
  const NovelView huge =
      NovelView::FromFov(8192, 8192, 1.0, LookAt(kCentre + Eigen::Vector3d(2, 0, -0.5), kCentre, {0, 0, -1}));
  const auto scene = dir_ / "heavy.yaml";
  {
    std::ofstream f(scene);
    f << "gravity: [0, 0, 9.81]\nballs: []\ncloth:\n  rod_a: [5, 0, -2]\n  rod_b: [6, 0, -2]\n  length: 1\n"
         "  nx: 400\n  ny: 250\n  iterations: 200\n  max_substep: 0.0001\n";
  }
  struct Case {
    const char* exe;
    std::vector<std::string> args;
    std::regex working;  // its debug line once the long work has begun
  };
  const std::vector<Case> cases = {
      {"recon_node",
       {"--tile", "0/1", "--planes", "4096", "--refine", "0", "--backend", "cpu", "--log-level", "debug"},
       std::regex("sweeping a 8192x8192 view, 4096 planes")},
      // The first frameset steps 0 s; a later one steps the source time between them.
      {"sim_node", {"--scene", scene.string(), "--log-level", "debug"}, std::regex("stepping the scene 0\\.0*[1-9]")},
  };
  Writer<hullpipe_msg_CameraInfo> info(*participant_);
  Writer<hullpipe_msg_ObjectPixelMap> maps(*participant_);
  Writer<hullpipe_msg_CameraImage> images(*participant_);
  Writer<hullpipe_msg_ViewPose> poses(*participant_);
  uint64_t seq = 0;
  for (const auto& c : cases) {
    auto node = Start(c.exe, c.args);
    WaitMatched(maps, 1);
    // Frames (and, for recon, the huge view) until the node logs that it works
    // on one: volatile readers drop what came before they matched.
    const double deadline = MonotonicSeconds() + 30;
    while (!std::regex_search(test::ReadFile(log_), c.working) && MonotonicSeconds() < deadline) {
      WriteFrameset(info, maps, images, views, img, ++seq);
      poses.Write(ViewToMsg(huge, seq, seq, NowNs()));
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
    ASSERT_TRUE(std::regex_search(test::ReadFile(log_), c.working)) << c.exe << ":\n" << test::ReadFile(log_);
    ExpectStopsWithinASecondOfSigintMidWork(*node, c.exe);
  }
}

// SIGINT while sim_node imports a CAD model (a 2,000,000-triangle binary STL,
// about 2 s to import here) once ended it by the signal: the importer child
// now ends within 0.2 s of the stop request and the node exits 0. Seen in that
// state by its "loading" line; the log's "import interrupted" is the positive
// control that the signal came mid-import.
TEST_F(NodeTest, SimStopsWithinASecondOfSigintDuringAModelImport) {
  const auto stl = dir_ / "big.stl";
  {
    constexpr uint32_t kTriangles = 2'000'000;
    std::ofstream f(stl, std::ios::binary);
    const std::string header(80, ' ');
    f.write(header.data(), 80);
    f.write(reinterpret_cast<const char*>(&kTriangles), 4);
    std::vector<char> rec(size_t(kTriangles) * 50, 0);
    for (uint32_t k = 0; k < kTriangles; ++k) {
      const float x = float(k % 1000) * 1e-3f, y = float(k / 1000 % 1000) * 1e-3f, z = float(k / 1000000) * 1e-3f;
      const float v[12] = {0, 0, 1, x, y, z, x + 5e-4f, y, z, x, y + 5e-4f, z};
      std::memcpy(rec.data() + size_t(k) * 50, v, sizeof(v));
    }
    f.write(rec.data(), std::streamsize(rec.size()));
  }
  const auto scene = dir_ / "big.yaml";
  std::ofstream(scene) << "balls: []\nmodels:\n  - {file: " << stl.string() << ", units: m}\n";
  auto node = Start("sim_node", {"--scene", scene.string()});
  const double deadline = MonotonicSeconds() + 30;
  while (test::ReadFile(log_).find("importing its models") == std::string::npos && MonotonicSeconds() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_TRUE(node->Running()) << test::ReadFile(log_);
  node->Signal(SIGINT);
  const double t0 = MonotonicSeconds();
  const int rc = node->Wait(10);
  const double took = MonotonicSeconds() - t0;
  const std::string log = test::ReadFile(log_);
  EXPECT_EQ(rc, 0) << log;
  EXPECT_LT(took, 1.0 * test::TimeScale()) << "took " << took << " s to stop\n" << log;
  EXPECT_NE(log.find("import interrupted by a stop request"), std::string::npos) << log;
}

// Mid-composite: render_node compositing the largest view it draws in one row
// band (8192x4096; about 1.5 s here, 8192x8192 about 3 s). A small tile
// answers its pose (a view need not be covered by its tiles), so the test
// sends kilobytes, not the view. Seen in that state first by its debug line;
// it must log that the composite was interrupted (the positive control that
// the signal came mid-composite) and exit 0 within a second.
TEST_F(NodeTest, RenderStopsWithinASecondOfSigintMidComposite) {
  const auto views = test::SphereViews(2, 64, 48, kCentre, 0.3);
  const cv::Mat img(48, 64, CV_8UC3, cv::Scalar(50, 60, 70));
  auto node = Start("render_node", {"--out", (dir_ / "render_big").string(), "--width", "8192", "--height", "4096",
                                    "--tiles", "1", "--log-level", "debug"});
  Writer<hullpipe_msg_CameraInfo> info(*participant_);
  Writer<hullpipe_msg_ObjectPixelMap> maps(*participant_);
  Writer<hullpipe_msg_CameraImage> images(*participant_);
  Writer<hullpipe_msg_HullView> tiles(*participant_);
  Reader<hullpipe_msg_ViewPose> poses(*participant_);
  WaitMatched(maps, 1);
  WaitMatched(tiles, 1);
  const std::regex working("compositing a 8192x4096 view");
  uint64_t seq = 0;
  for (const double deadline = MonotonicSeconds() + 30;
       !std::regex_search(test::ReadFile(log_), working) && MonotonicSeconds() < deadline;) {
    WriteFrameset(info, maps, images, views, img, ++seq);
    // Each pose render asks for is answered with one 64x48 tile (its run id echoed).
    poses.TakeEach([&](const hullpipe_msg_ViewPose& p, const dds_sample_info_t&) {
      HullTile tile;
      tile.rect = {0, 0, 64, 48};
      tile.depth = cv::Mat(48, 64, CV_32FC1, cv::Scalar(2));
      tile.colour = cv::Mat(48, 64, CV_8UC3, cv::Scalar(0, 200, 0));
      tile.pose_seq = p.pose_seq;
      tile.frame_seq = p.frame_seq;
      tile.run_id = p.run_id;
      tiles.Write(MakeHullViewMessage(tile, 1).msg);
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_TRUE(std::regex_search(test::ReadFile(log_), working)) << test::ReadFile(log_);
  ExpectStopsWithinASecondOfSigintMidWork(*node, "render_node");
}

// --- capture_node on broken files (needs the Utrecht rig) -------------------

// Each test's deadline covers reading the videos, so it stretches with
// TimeScale(): under ThreadSanitizer four cameras' 128 frames took 36 s, and
// past 60 s beside another test.
class CaptureFiles : public NodeTest {
 protected:
  void SetUp() override {
    if (!test::HaveRig()) GTEST_SKIP() << "no rig at " << test::RigDir();
    NodeTest::SetUp();
    rig_ = dir_ / "rig";
    for (int c = 1; c <= 4; ++c) {
      const auto src = std::filesystem::path(test::RigDir()) / ("cam" + std::to_string(c));
      const auto dst = rig_ / ("cam" + std::to_string(c));
      std::filesystem::create_directories(dst);
      for (const char* f : {"config.xml", "background.avi", "video.avi"})
        std::filesystem::copy_file(src / f, dst / f);
    }
  }
  std::filesystem::path rig_;
};

// Published frames, from capture's last line "published N frames, ...".
int PublishedFrames(const std::string& log) {
  const auto at = log.rfind("published ");
  return at == std::string::npos ? -1 : std::atoi(log.c_str() + at + 10);
}

// A video cut mid-run once ended capture with exit 0 while frames vanished
// downstream (three cameras went on alone; no frameset completes without the
// fourth). Now the input ends at the short camera: its good frames are
// published, one line names the camera, and the exit is 3.
TEST_F(CaptureFiles, TruncatedVideoEndsTheInputThereWithExit3) {
  // Cut cam2's video to 40% of its bytes: the tail is gone mid-frame.
  const auto video = rig_ / "cam2" / "video.avi";
  std::filesystem::resize_file(video, std::filesystem::file_size(video) * 4 / 10);
  auto node = Start("capture_node", {"--rig", rig_.string(), "--fast"});
  EXPECT_EQ(node->Wait(60 * test::TimeScale()), 3) << test::ReadFile(log_);
  const std::string log = test::ReadFile(log_);
  EXPECT_NE(log.find("camera(s) 2 ended after frame"), std::string::npos) << log;
  EXPECT_NE(log.find("camera(s) 1, 3, 4 went on"), std::string::npos) << log;
  // 40% of the bytes decode to ~128 of the 426 frames: those are published.
  EXPECT_GT(PublishedFrames(log), 100) << log;
  EXPECT_LT(PublishedFrames(log), 200) << log;
}

// Every camera cut alike: they end together, but each well before the frame
// count its container declares (428): a truncated input, not its end.
TEST_F(CaptureFiles, EveryVideoTruncatedAlikeIsStillCaught) {
  for (int c = 1; c <= 4; ++c) {
    const auto video = rig_ / ("cam" + std::to_string(c)) / "video.avi";
    std::filesystem::resize_file(video, std::filesystem::file_size(video) * 4 / 10);
  }
  auto node = Start("capture_node", {"--rig", rig_.string(), "--fast", "--cameras", "2"});
  EXPECT_EQ(node->Wait(60 * test::TimeScale()), 3) << test::ReadFile(log_);
  const std::string log = test::ReadFile(log_);
  EXPECT_NE(log.find("its container declares (truncated or damaged)"), std::string::npos) << log;
  EXPECT_GT(PublishedFrames(log), 100) << log;
}

// Positive control for the two above: the whole video ends with exit 0 (426
// frames read against 428 declared is within the container's estimate).
TEST_F(CaptureFiles, TheWholeVideoEndsWithExit0) {
  auto node = Start("capture_node", {"--rig", rig_.string(), "--fast", "--cameras", "1"});
  EXPECT_EQ(node->Wait(120 * test::TimeScale()), 0) << test::ReadFile(log_);
  EXPECT_EQ(PublishedFrames(test::ReadFile(log_)), 426) << test::ReadFile(log_);
}

// A camera without frames (a valid container, zero frames) once let the run
// composite nothing with exit 0.
TEST_F(CaptureFiles, ACameraWithNoFramesIsAnError) {
  {
    cv::VideoWriter empty((rig_ / "cam3" / "video.avi").string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 50,
                          cv::Size(644, 486));
    ASSERT_TRUE(empty.isOpened());
  }
  auto node = Start("capture_node", {"--rig", rig_.string(), "--fast"});
  const int rc = node->Wait(60 * test::TimeScale());
  EXPECT_NE(rc, 0) << test::ReadFile(log_);
  const std::string log = test::ReadFile(log_);
  EXPECT_EQ(rc, 3) << log;
  EXPECT_NE(log.find("camera(s) 3 ended after frame 0 while camera(s) 1, 2, 4 went on"), std::string::npos) << log;
  EXPECT_LE(PublishedFrames(log), 0) << log;
}

// A camera's video that is not there ends the node before its first frame
// with one line naming the camera and the file (camera_reader.h).
TEST_F(CaptureFiles, AMissingVideoNamesTheCameraAndTheFile) {
  std::filesystem::remove(rig_ / "cam3" / "video.avi");
  auto node = Start("capture_node", {"--rig", rig_.string(), "--fast"});
  EXPECT_EQ(node->Wait(30), 1);
  const std::string log = test::ReadFile(log_);
  EXPECT_NE(log.find("camera 3: cannot open"), std::string::npos) << log;
  EXPECT_NE(log.find("cam3/video.avi"), std::string::npos) << log;
  EXPECT_LE(PublishedFrames(log), 0) << log;
}

TEST_F(CaptureFiles, CalibrationMissingAKeyIsAOneLineError) {
  const auto cfg = rig_ / "cam3" / "config.xml";
  std::string text = test::ReadFile(cfg.string());
  text.erase(text.find("<Translation"), text.find("</Translation>") + 14 - text.find("<Translation"));
  std::ofstream(cfg) << text;
  auto node = Start("capture_node", {"--rig", rig_.string(), "--fast"});
  EXPECT_EQ(node->Wait(30), 1);
  const std::string log = test::ReadFile(log_);
  EXPECT_NE(log.find("cam3/config.xml: missing key 'Translation'"), std::string::npos) << log;
}

TEST_F(CaptureFiles, GarbageVideoIsAClearError) {
  std::ofstream(rig_ / "cam1" / "video.avi", std::ios::trunc) << std::string(5000, 'x');
  auto node = Start("capture_node", {"--rig", rig_.string(), "--fast"});
  EXPECT_EQ(node->Wait(30), 1);
  const std::string log = test::ReadFile(log_);
  EXPECT_NE(log.find("camera 1"), std::string::npos) << log;
}

}  // namespace
}  // namespace hullpipe
