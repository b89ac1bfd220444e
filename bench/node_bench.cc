// node_bench: one node alone, fed as fast as it takes its input (docs/architecture.md).
//   node_bench --node sim   --recording run.hprec [--frames 200]
//   node_bench --node recon --recording run.hprec [--views first] [--tile 0/2] [--threads 1]
//   node_bench --node render --recording run.hprec   (needs hull_view in it)
//   node_bench --node capture --rig ../shared/data/utrecht-4cam
// sim and recon run closed-loop on a replayed recording (hullpipe_record): the
// bench publishes frameset f byte for byte (plus, for recon, the recorded
// ViewPoses naming f: both eyes' of a stereo run, or with --views first only
// the first, the left eye, as a mono frame of the same view), waits for the
// node's output for f (CollisionReport or VirtualMesh / a HullView for each
// ViewPose), then sends f+1 (a frameset with no output in 3 s counts as a
// timeout). Throughput is framesets per second of that loop;
// latency is, per frameset, the output's arrival minus the moment its last input
// was written (both on this machine's clock). capture runs on its own input
// (--fast) and its latency is a map's arrival minus its capture_time_ns. CPU is
// the node's user+system time over the run's wall time (/proc), memory its peak
// resident set (VmHWM). Each run uses its own DDS domain on loopback.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <thread>

#include <CLI/CLI.hpp>

#include "hullpipe/launch/cyclone_config.h"
#include "hullpipe/launch/domain.h"
#include "hullpipe/launch/process.h"
#include <nlohmann/json.hpp>

#include "hullpipe/util/percentile.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/record/recording.h"
#include "hullpipe/util/logging.h"
#include "hullpipe/util/memory.h"

using namespace hullpipe;
using namespace hullpipe::dds;
using namespace hullpipe::record;
namespace fs = std::filesystem;
namespace launch = hullpipe::launch;

namespace {

// CPU seconds (user + system) of a process.
double CpuSeconds(pid_t pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
  std::string s((std::istreambuf_iterator<char>(f)), {});
  const auto close = s.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream in(s.substr(close + 2));
  std::string field;
  double ut = 0, st = 0;
  for (int k = 3; k <= 15 && in >> field; ++k) {
    if (k == 14) ut = std::stod(field);
    if (k == 15) st = std::stod(field);
  }
  return (ut + st) / double(sysconf(_SC_CLK_TCK));
}

double PeakRssMiB(pid_t pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  return 0;
}

struct Result {
  std::string node;
  int frames = 0, timeouts = 0;
  int64_t view_poses_sent = 0;  // recon: the ViewPoses written (two a frameset for a stereo run's both eyes)
  double seconds = 0, cpu_s = 0, rss_mib = 0;
  std::vector<double> latency_ms;
  /// One frameset's outcome: its output came `since` (monotonic s) ago, or not.
  void Count(bool got, double since) {
    if (got) {
      latency_ms.push_back((MonotonicSeconds() - since) * 1e3);
      ++frames;
    } else {
      ++timeouts;
    }
  }
  /// The run's wall time, the node's CPU time since cpu0 and its peak memory.
  void Finish(pid_t pid, double t0, double cpu0) {
    seconds = MonotonicSeconds() - t0;
    cpu_s = CpuSeconds(pid) - cpu0;
    rss_mib = PeakRssMiB(pid);
  }
};

// Recorded samples of a topic, by name.
struct Recorded {
  TopicInfo topic;
  std::vector<Sample> samples;
};

std::map<std::string, Recorded> Load(const std::string& path, const std::vector<std::string>& names) {
  const RecordingReader rec(path);
  std::map<std::string, Recorded> out;
  std::map<int64_t, std::string> by_id;
  for (const auto& t : rec.topics())
    if (std::find(names.begin(), names.end(), t.name) != names.end()) {
      by_id[t.id] = t.name;
      out[t.name].topic = t;
    }
  rec.ForEach([&](const Sample& s) {
    out[by_id.at(s.topic_id)].samples.push_back(s);
    return true;
  }, [&] {
    std::vector<int64_t> ids;
    for (const auto& [id, n] : by_id) ids.push_back(id);
    return ids;
  }());
  return out;
}

// A serialized writer for a recorded topic, with its recorded QoS.
std::unique_ptr<CdrWriter> WriterFor(const Participant& p, const Recorded& r0) {
  const KnownType* kt = FindKnownType(r0.topic.type);
  if (!kt) throw std::runtime_error("unknown type " + r0.topic.type);
  return std::make_unique<CdrWriter>(p, *kt, QosSpec{r0.topic.reliable, r0.topic.transient_local, r0.topic.depth});
}

// get(m) of a recorded sample m of type T (decoded with the writer's type); 0
// if it does not decode.
template <typename T, typename Get>
uint64_t FieldOf(const CdrWriter& w, const Sample& s, Get get) {
  T m{};
  if (!w.Decode(s.data, &m)) return 0;
  const uint64_t v = get(m);
  dds_sample_free(&m, TopicTraits<T>::Descriptor(), DDS_FREE_CONTENTS);
  return v;
}

// The frame_seq of a recorded sample of type T.
template <typename T>
uint64_t FrameOf(const CdrWriter& w, const Sample& s) {
  return FieldOf<T>(w, s, [](const T& m) { return uint64_t(m.frame_seq); });
}

// The pose_seq of a recorded ViewPose.
uint64_t PoseSeqOf(const CdrWriter& w, const Sample& s) {
  return FieldOf<hullpipe_msg_ViewPose>(w, s, [](const hullpipe_msg_ViewPose& m) { return uint64_t(m.pose_seq); });
}

// first_view_only (recon): send only the first recorded ViewPose of each frameset.
Result BenchReplayed(const std::string& node, const Participant& p, pid_t pid, const std::string& recording,
                     int max_frames, bool first_view_only) {
  Result r;
  r.node = node;
  const bool recon = node == "recon";
  std::vector<std::string> names = {"hullpipe/camera_info", "hullpipe/object_pixel_map"};
  if (recon) names.insert(names.end(), {"hullpipe/camera_image", "hullpipe/view_pose"});
  auto rec = Load(recording, names);
  for (const auto& n : names)
    if (rec[n].samples.empty()) throw std::runtime_error(recording + ": no " + n + " samples");
  auto writer_for = [&](const std::string& topic_name) { return WriterFor(p, rec.at(topic_name)); };
  auto info_w = writer_for("hullpipe/camera_info");
  auto map_w = writer_for("hullpipe/object_pixel_map");
  std::unique_ptr<CdrWriter> img_w, pose_w;
  if (recon) img_w = writer_for("hullpipe/camera_image"), pose_w = writer_for("hullpipe/view_pose");
  // Inputs grouped by frameset.
  std::map<uint64_t, std::vector<const Sample*>> maps, images;
  // Per frameset its ViewPoses in pose order (a stereo run's two eyes), with their pose_seq.
  std::map<uint64_t, std::vector<std::pair<uint64_t, const Sample*>>> poses;
  for (const auto& s : rec["hullpipe/object_pixel_map"].samples)
    maps[FrameOf<hullpipe_msg_ObjectPixelMap>(*map_w, s)].push_back(&s);
  if (recon) {
    for (const auto& s : rec["hullpipe/camera_image"].samples)
      images[FrameOf<hullpipe_msg_CameraImage>(*img_w, s)].push_back(&s);
    for (const auto& s : rec["hullpipe/view_pose"].samples) {
      const uint64_t f = FrameOf<hullpipe_msg_ViewPose>(*pose_w, s);
      if (f == 0) continue;
      auto& fp = poses[f];
      const uint64_t k = PoseSeqOf(*pose_w, s);
      const bool seen = std::any_of(fp.begin(), fp.end(), [&](const auto& e) { return e.first == k; });
      if (!seen && !(first_view_only && !fp.empty())) fp.emplace_back(k, &s);
    }
  }
  Reader<hullpipe_msg_CollisionReport> reports(p);  // sim: per ball...
  Reader<hullpipe_msg_VirtualMesh> meshes(p);       // ...or per cloth, particle set, payload part
  Reader<hullpipe_msg_HullView> tiles(p);
  // Wait until the node is there, then send the calibration.
  const double until = MonotonicSeconds() + 20;
  while (map_w->MatchedReaders() == 0 && MonotonicSeconds() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  if (map_w->MatchedReaders() == 0) throw std::runtime_error(node + "_node did not appear on the domain");
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // its side matches too
  for (const auto& s : rec["hullpipe/camera_info"].samples) info_w->Write(s.data);
  const double cpu0 = CpuSeconds(pid), t0 = MonotonicSeconds();
  for (const auto& entry : maps) {
    const auto f = entry.first;  // (a structured binding cannot be captured by clang 14's lambdas)
    const auto& ms = entry.second;
    if (max_frames > 0 && r.frames + r.timeouts >= max_frames) break;
    if (recon && !poses.count(f)) continue;
    if (recon)
      for (const Sample* s : images[f]) img_w->Write(s->data);
    for (const Sample* s : ms) map_w->Write(s->data);
    // recon: the pose_seqs still awaiting their HullView.
    std::vector<uint64_t> awaited;
    if (recon)
      for (const auto& [k, s] : poses[f]) pose_w->Write(s->data), awaited.push_back(k), ++r.view_poses_sent;
    const double sent = MonotonicSeconds();
    bool got = false;
    while (!got && MonotonicSeconds() - sent < 3.0) {
      if (recon) {
        tiles.TakeEach([&](const hullpipe_msg_HullView& m, const dds_sample_info_t&) {
          if (m.frame_seq == f) std::erase(awaited, m.pose_seq);
        });
        got = awaited.empty();
      } else {
        reports.TakeEach(
            [&](const hullpipe_msg_CollisionReport& m, const dds_sample_info_t&) { got = got || m.frame_seq == f; });
        meshes.TakeEach(
            [&](const hullpipe_msg_VirtualMesh& m, const dds_sample_info_t&) { got = got || m.frame_seq == f; });
      }
      if (!got) std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    r.Count(got, sent);
  }
  r.Finish(pid, t0, cpu0);
  return r;
}

// render: the bench plays capture (recorded maps) and the recon nodes (the
// recorded tiles of the frameset, relabelled with render's new pose_seq and
// run id). With
// --max-in-flight 1 render asks for frameset f+1 only once f is composited, so
// the loop is: maps of f -> ViewPose(f) -> tiles of f, maps of f+1 ->
// ViewPose(f+1) = f composited. Latency: tiles of f written -> ViewPose(f+1).
Result BenchRender(const Participant& p, pid_t pid, const std::string& recording, int max_frames) {
  Result r;
  r.node = "render";
  const std::vector<std::string> names = {"hullpipe/camera_info", "hullpipe/object_pixel_map", "hullpipe/hull_view",
                                          "hullpipe/object_state"};
  auto rec = Load(recording, names);
  for (const char* n : {"hullpipe/camera_info", "hullpipe/object_pixel_map", "hullpipe/hull_view"})
    if (rec[n].samples.empty()) throw std::runtime_error(recording + ": no " + std::string(n) + " samples");
  auto writer_for = [&](const std::string& topic_name) { return WriterFor(p, rec.at(topic_name)); };
  auto info_w = writer_for("hullpipe/camera_info");
  auto map_w = writer_for("hullpipe/object_pixel_map");
  auto tile_decoder = writer_for("hullpipe/hull_view");
  std::unique_ptr<CdrWriter> state_w;
  if (!rec["hullpipe/object_state"].samples.empty()) state_w = writer_for("hullpipe/object_state");
  Writer<hullpipe_msg_HullView> tiles(p);
  Reader<hullpipe_msg_ViewPose> poses(p);
  std::map<uint64_t, std::vector<const Sample*>> maps, states;
  std::map<uint64_t, std::map<uint32_t, const Sample*>> frame_tiles;  // frame -> tile index -> sample
  for (const auto& s : rec["hullpipe/object_pixel_map"].samples)
    maps[FrameOf<hullpipe_msg_ObjectPixelMap>(*map_w, s)].push_back(&s);
  if (state_w)
    for (const auto& s : rec["hullpipe/object_state"].samples)
      states[FrameOf<hullpipe_msg_VirtualObjectState>(*state_w, s)].push_back(&s);
  for (const auto& s : rec["hullpipe/hull_view"].samples) {
    hullpipe_msg_HullView m{};
    if (!tile_decoder->Decode(s.data, &m)) continue;
    frame_tiles[m.frame_seq][m.tile_index] = &s;
    dds_sample_free(&m, TopicTraits<hullpipe_msg_HullView>::Descriptor(), DDS_FREE_CONTENTS);
  }
  std::vector<uint64_t> frames;
  for (const auto& [f, t] : frame_tiles)
    if (t.size() == 2 && maps.count(f)) frames.push_back(f);
  const double until = MonotonicSeconds() + 20;
  while ((map_w->MatchedReaders() == 0 || tiles.MatchedReaders() == 0) && MonotonicSeconds() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  if (map_w->MatchedReaders() == 0) throw std::runtime_error("render_node did not appear on the domain");
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  for (const auto& s : rec["hullpipe/camera_info"].samples) info_w->Write(s.data);
  auto wait_pose = [&](uint64_t f, hullpipe_msg_ViewPose* out) {
    const double t0 = MonotonicSeconds();
    bool got = false;
    while (!got && MonotonicSeconds() - t0 < 3.0) {
      poses.TakeEach([&](const hullpipe_msg_ViewPose& m, const dds_sample_info_t&) {
        if (m.frame_seq == f) got = true, *out = m;
      });
      if (!got) std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    return got;
  };
  auto send_maps = [&](uint64_t f) {
    for (const Sample* s : states[f]) state_w->Write(s->data);
    for (const Sample* s : maps[f]) map_w->Write(s->data);
  };
  const double cpu0 = CpuSeconds(pid), t0 = MonotonicSeconds();
  if (frames.empty()) throw std::runtime_error(recording + ": no frameset with both tiles and maps");
  send_maps(frames[0]);
  hullpipe_msg_ViewPose pose{};
  bool have = wait_pose(frames[0], &pose);
  for (size_t k = 0; k < frames.size() && have; ++k) {
    if (max_frames > 0 && r.frames >= max_frames) break;
    for (const auto& [idx, s] : frame_tiles[frames[k]]) {
      hullpipe_msg_HullView m{};
      tile_decoder->Decode(s->data, &m);
      m.pose_seq = pose.pose_seq;
      m.run_id = pose.run_id;  // the answer to render's pose, as a recon node's tile is
      tiles.Write(m);
      dds_sample_free(&m, TopicTraits<hullpipe_msg_HullView>::Descriptor(), DDS_FREE_CONTENTS);
    }
    const double sent = MonotonicSeconds();
    if (k + 1 == frames.size()) break;
    send_maps(frames[k + 1]);
    have = wait_pose(frames[k + 1], &pose);
    r.Count(have, sent);
  }
  r.Finish(pid, t0, cpu0);
  return r;
}

Result BenchCapture(const Participant& p, launch::Process& proc, int max_frames) {
  const pid_t pid = proc.pid();
  Result r;
  r.node = "capture";
  Reader<hullpipe_msg_ObjectPixelMap> maps(p);
  std::map<uint64_t, int> per_frame;
  const double cpu0 = CpuSeconds(pid), t0 = MonotonicSeconds();
  double last = t0;
  while (proc.Running() || maps.TakeEach([](auto&, auto&) {}) > 0) {
    maps.TakeEach([&](const hullpipe_msg_ObjectPixelMap& m, const dds_sample_info_t&) {
      if (++per_frame[m.frame_seq] == int(m.camera_count)) {
        r.latency_ms.push_back(double(NowNs() - m.capture_time_ns) * 1e-6);
        ++r.frames;
        last = MonotonicSeconds();
        r.cpu_s = CpuSeconds(pid) - cpu0;
        r.rss_mib = std::max(r.rss_mib, PeakRssMiB(pid));
      }
    });
    if (max_frames > 0 && r.frames >= max_frames) break;
    std::this_thread::sleep_for(std::chrono::microseconds(500));
    if (MonotonicSeconds() - last > 10) break;
  }
  r.seconds = last - t0;
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  hullpipe::LogToStderr("node_bench");  // stdout carries only what a user asked for
  hullpipe::KeepFreedMemory();  // as the nodes do (util/memory.h): no page faults per frameset
  hullpipe::SetCommandLine(argc, argv);
  CLI::App app{"node_bench: one hullpipe node alone, fed as fast as it takes input"};
  std::string node, recording, rig, bin_dir = fs::path(argv[0]).parent_path().string(), scene;
  std::string tile = "0/1", views = "all";
  int frames = 0, threads = -1;
  bool json = false;
  app.add_option("--node", node, "capture | recon | sim | render")
      ->required()
      ->check(CLI::IsMember({"capture", "recon", "sim", "render"}));
  app.add_option("--recording", recording, "Recording to feed recon or sim (hullpipe_record)");
  app.add_option("--rig", rig, "Rig directory for capture");
  app.add_option("--frames", frames, "Stop after this many framesets (0: all)");
  app.add_option("--scene", scene, "sim_node's scene file");
  app.add_option("--views", views,
                 "recon: each frameset's recorded ViewPoses to send, all (a stereo run's two eyes) or first (its "
                 "left eye alone: the mono frame of the same view)")
      ->check(CLI::IsMember({"all", "first"}))
      ->capture_default_str();
  app.add_option("--tile", tile, "recon: its --tile i/N (0/1: the whole view; of several, it adopts no other)")
      ->capture_default_str();
  app.add_option("--threads", threads, "recon: its --threads (unset: the node's default)")->check(CLI::Range(0, 256));
  app.add_option("--bin-dir", bin_dir, "Where the node executables are")->capture_default_str();
  app.add_flag("--json", json, "One JSON object");
  CLI11_PARSE(app, argc, argv);
  try {
    const fs::path dir = fs::temp_directory_path() / ("node_bench_" + std::to_string(getpid()));
    fs::create_directories(dir);
    const std::string config = (dir / "cyclonedds.xml").string();
    launch::CycloneConfigOptions cfg;
    cfg.comment = "Written by node_bench: loopback, as hullpipe_launch's";
    launch::WriteCycloneConfig(config, cfg);
    setenv("CYCLONEDDS_URI", ("file://" + config).c_str(), 1);
    const launch::DomainLease lease;  // no other live run on this machine holds it
    const uint32_t domain = lease.id();
    std::vector<std::string> args = {bin_dir + "/" + node + "_node", "--domain", std::to_string(domain)};
    if (node == "recon") args.insert(args.end(), {"--tile", tile});
    // A tile of several: no peer plays the others here, and the node would
    // adopt their tiles after its fail-over time (recon_controller.h).
    if (node == "recon" && tile.substr(tile.find('/') + 1) != "1") args.insert(args.end(), {"--failover", "3600"});
    if (node == "recon" && threads >= 0) args.insert(args.end(), {"--threads", std::to_string(threads)});
    if (node == "render")
      args.insert(args.end(), {"--out", (dir / "out").string(), "--tiles", "2", "--max-in-flight", "1", "--window",
                               "off", "--idle-timeout", "30", "--tile-timeout", "5"});
    if (node == "sim" && !scene.empty()) args.insert(args.end(), {"--scene", fs::absolute(scene).string()});
    if (node == "capture") {
      if (rig.empty()) throw std::runtime_error("--node capture needs --rig DIR");
      args.insert(args.end(), {"--rig", rig, "--fast", "--wait-readers", "1"});
      if (frames > 0) args.insert(args.end(), {"--frames", std::to_string(frames)});
    } else if (recording.empty()) {
      throw std::runtime_error("--node " + node + " needs --recording FILE");
    }
    const std::string log = (dir / (node + ".log")).string();
    Participant p(domain);
    launch::Process proc(args, log);
    const pid_t pid = proc.pid();
    Result r;
    try {
      r = node == "capture"  ? BenchCapture(p, proc, frames)
          : node == "render" ? BenchRender(p, pid, recording, frames)
                             : BenchReplayed(node, p, pid, recording, frames, views == "first");
    } catch (const std::exception& e) {
      // A node that refused its arguments (a bad --tile) has said which: its last line.
      if (proc.Running()) throw;
      std::ifstream in(log);
      std::string line, last;
      while (std::getline(in, line))
        if (!line.empty()) last = line;
      throw std::runtime_error(std::string(e.what()) + "; " + node + "_node exited: " + last);
    }
    proc.Stop(10);
    const double fps = r.seconds > 0 ? r.frames / r.seconds : 0;
    if (json) {
      nlohmann::json j = {{"node", r.node},
                          {"frames", r.frames},
                          {"timeouts", r.timeouts},
                          {"fps", fps},
                          {"latency_ms_p50", Percentile(r.latency_ms, 50)},
                          {"latency_ms_p95", Percentile(r.latency_ms, 95)},
                          {"latency_ms_p99", Percentile(r.latency_ms, 99)},
                          {"cpu_percent", r.seconds > 0 ? 100 * r.cpu_s / r.seconds : 0},
                          {"cpu_ms_per_frameset", r.frames > 0 ? 1e3 * r.cpu_s / r.frames : 0},
                          {"peak_rss_mib", r.rss_mib}};
      if (node == "recon") j["views"] = views, j["tile"] = tile, j["view_poses_sent"] = r.view_poses_sent;
      j["command"] = CommandLine();
      std::printf("%s\n", j.dump().c_str());
    } else {
      const std::string name = r.node + (scene.empty() ? "" : " (" + fs::path(scene).stem().string() + ")");
      std::printf("| %-8s | %6d | %8.1f | %8.1f | %8.1f | %8.1f | %6.0f | %8.0f | %8d |\n", name.c_str(), r.frames, fps,
                  Percentile(r.latency_ms, 50), Percentile(r.latency_ms, 95), Percentile(r.latency_ms, 99),
                  r.seconds > 0 ? 100 * r.cpu_s / r.seconds : 0.0, r.rss_mib, r.timeouts);
    }
    fs::remove_all(dir);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "node_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
