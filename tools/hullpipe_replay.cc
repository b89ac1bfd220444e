// hullpipe_replay: publishes a recording (hullpipe_record) back onto a domain
// (docs/architecture.md), each topic with its original QoS, so a late-joining node still gets
// the transient-local CameraInfo.
//   hullpipe_replay run.hprec --domain 8 [--rate 0.5] [--loop] [--start-offset 2.0]
//                   [--end 8.0 | --duration 6.0] [--start-paused]
//                   [--include 'hullpipe/object_pixel_map'] [--wait-readers 2]
// A recording is a file or a split recording's directory (docs/recording.md).
// Timing: the original arrival times divided by --rate; --rate 0 publishes as
// fast as the readers take it (each sample waits for its readers' acknowledgement).
// Topics: by default only what the nodes consume (calibration, maps, images, head
// poses, scene commands), so a replay into live nodes does not mix a recorded
// run's outputs (views, tiles, NodeStats) with theirs; --all-topics plays all.
// Keys on a terminal: space pauses and resumes, s steps one sample while paused,
// ] and [ double and halve the rate, . and , seek 5 s forward and back, 0 seeks
// to the start, q quits. The same from
// the domain: `hullpipe_cmd pause|resume|step N|seek S|rate X` (RecordCommand).
// Samples are written byte for byte as recorded (dds_writecdr).
#include <algorithm>
#include <map>
#include <memory>
#include <set>
#include <thread>

#include <CLI/CLI.hpp>
#include <spdlog/fmt/ranges.h>
#include <spdlog/spdlog.h>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/record/player.h"
#include "hullpipe/util/logging.h"
#include "replay_control.h"

using namespace hullpipe;
using namespace hullpipe::dds;
using namespace hullpipe::record;

namespace {

// What the nodes consume; the rest is what they produce.
const std::vector<std::string> kInputTopics = {"hullpipe/camera_info", "hullpipe/object_pixel_map",
                                               "hullpipe/camera_image", "hullpipe/head_pose",
                                               "hullpipe/scene_command"};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hullpipe_replay: publish a recording with its original QoS and timing"};
  CommonOptions common;
  OpenCommandLine(argc, argv, "hullpipe_replay", app, common);
  std::string path;
  PlayerOptions po;
  int wait_readers = 0;
  std::string wait_topic = "hullpipe/object_pixel_map";
  double wait_timeout = 20, linger = 1.0, settle = 0.5;
  bool keyboard = true, all_topics = false;
  app.add_option("recording", path, "Recording file (hullpipe_record -o)")->required();
  app.add_option("--rate", po.rate, "Speed factor; 0: as fast as the readers take it")->capture_default_str();
  app.add_flag("--loop", po.loop, "Start over at the end");
  app.add_option("--max-loops", po.max_loops, "With --loop: stop after this many passes");
  app.add_option("--start-offset", po.start_offset_s, "Skip this many seconds (transient-local state still sent)");
  double duration = 0;
  bool start_paused = false;
  app.add_option("--end", po.end_offset_s, "Stop at this many seconds after the recording's start");
  app.add_option("--duration", duration, "Stop after this many seconds of the recording (from --start-offset)");
  app.add_flag("--start-paused", start_paused, "Start paused (space, or hullpipe_cmd resume/step, goes on)");
  app.add_option("--include", po.include, "Replay only topics matching these globs (default: the nodes' inputs)");
  app.add_flag("--all-topics", all_topics, "Replay every topic, the recorded nodes' outputs too");
  app.add_option("--exclude", po.exclude, "Do not replay topics matching these globs");
  app.add_option("--wait-readers", wait_readers, "Before playing, wait until --wait-topic has this many readers");
  app.add_option("--wait-topic", wait_topic, "The topic --wait-readers counts on")->capture_default_str();
  app.add_option("--wait-timeout", wait_timeout, "Give up waiting for readers after this many s")
      ->capture_default_str();
  app.add_option("--settle", settle, "After --wait-readers matched: wait this long, so the readers' side has "
                 "matched too (else a volatile reader misses the first samples)")->capture_default_str();
  app.add_option("--linger", linger, "Stay this many s after the end (transient-local data stays available)")
      ->capture_default_str();
  app.add_flag("!--no-keyboard", keyboard, "Ignore the terminal (no pause/step keys)");
  CLI11_PARSE(app, argc, argv);
  try {
    if (duration != 0) {
      if (po.end_offset_s > 0) throw std::invalid_argument("give --end or --duration, not both");
      if (!(duration > 0 && duration <= PlayerOptions::kMaxStartOffsetS))
        throw std::invalid_argument("--duration must be in (0, 1e6] s");
      po.end_offset_s = po.start_offset_s + duration;
    }
    po.Check();
    if (wait_readers < 0 || wait_readers > 1000) throw std::invalid_argument("--wait-readers must be in [0, 1000]");
    for (const auto& [flag, v] : {std::pair<const char*, double>{"--wait-timeout", wait_timeout},
                                  {"--settle", settle}, {"--linger", linger}})
      if (!(v >= 0 && v <= 3600)) throw std::invalid_argument(std::string(flag) + " must be in [0, 3600] s");
    if (all_topics && !po.include.empty()) throw std::invalid_argument("--all-topics goes without --include");
    const RecordingReader rec(path);
    // Damage found before anything is published, rather than half-way.
    if (const std::string damage = rec.QuickCheck(); !damage.empty())
      throw std::runtime_error(path + ": damaged (" + damage + "); see hullpipe_record info");
    if (!rec.missing_parts().empty())
      spdlog::warn("{}: {}: replaying what the other parts hold", path, rec.missing_parts());
    if (po.include.empty() && !all_topics) {
      po.include = kInputTopics;
      std::vector<std::string> outputs;
      for (const auto& t : rec.topics())
        if (!TopicSelected(po.include, po.exclude, t.name)) outputs.push_back(t.name);
      if (!outputs.empty())
        spdlog::info("not replaying the recorded nodes' outputs ({}): --all-topics plays them",
                     fmt::join(outputs, ", "));
    }
    auto participant = StartNode("replay", common);
    std::map<int64_t, std::unique_ptr<CdrWriter>> writers;
    for (const auto& t : rec.topics()) {
      if (!TopicSelected(po.include, po.exclude, t.name)) continue;
      const KnownType* kt = FindKnownType(t.type);
      if (!kt || kt->topic_name != t.name) {
        spdlog::warn("topic {} of type {} is not a hullpipe type of this build; skipped", t.name, t.type);
        continue;
      }
      writers[t.id] = std::make_unique<CdrWriter>(*participant, *kt, QosSpec{t.reliable, t.transient_local, t.depth});
    }
    if (writers.empty()) throw std::runtime_error(path + ": no topic to replay (--include, --all-topics)");
    // Samples of a type whose IDL differs from this build's may not deserialize:
    // said before playing (recordings before format 3 carry no IDL).
    for (const auto& t : rec.topics())
      if (writers.count(t.id) && !t.type_description.empty() && t.type_description != IdlText())
        spdlog::warn("{}: recorded by a build with other IDL for {} (hullpipe_record info --idl shows it); samples "
                     "this build cannot read are refused and counted", t.name, t.type);
    std::vector<std::string> kept;
    for (const auto& t : rec.topics())
      if (writers.count(t.id)) kept.push_back(t.name);
    po.include = kept;  // the player plays exactly the topics that have a writer
    if (wait_readers > 0) {
      const double until = MonotonicSeconds() + wait_timeout;
      for (;;) {
        bool enough = false;
        for (const auto& t : rec.topics())
          if (t.name == wait_topic && writers.count(t.id))
            enough = int(writers.at(t.id)->MatchedReaders()) >= wait_readers;
        if (enough) break;
        if (MonotonicSeconds() > until) {
          spdlog::warn("{} has fewer than {} readers after {} s; playing anyway", wait_topic, wait_readers,
                       wait_timeout);
          break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
      std::this_thread::sleep_for(std::chrono::duration<double>(settle));
    }
    PlayerControl control;
    control.paused = start_paused;
    if (start_paused) spdlog::info("paused: space or `hullpipe_cmd resume` plays, s or `hullpipe_cmd step` steps");
    const Steering steering(&control, *participant);
    std::unique_ptr<Keyboard> keys;
    if (keyboard) keys = std::make_unique<Keyboard>(&control, po.rate);
    uint64_t refused = 0;
    std::set<std::string> refused_topics;  // one line per topic; all counted
    const PlayStats st = Play(rec, po, [&](const TopicInfo& t, const Sample& s) {
      const CdrWriter& w = *writers.at(t.id);
      try {
        w.Write(s.data);
      } catch (const std::invalid_argument& e) {
        ++refused;  // a corrupt sample, or another build's layout: skip it, keep playing
        if (refused_topics.insert(t.name).second)
          spdlog::warn("{}: sample at {} ns: {} (further refusals on this topic are counted, not logged)", t.name,
                       s.arrival_ns, e.what());
        return;
      }
      if (po.rate == 0) {
        const dds_return_t rc = dds_wait_for_acks(w.handle(), DDS_SECS(5));
        if (rc != DDS_RETCODE_TIMEOUT) Check(rc, "dds_wait_for_acks");
      }
    }, &control);
    for (const auto& [id, w] : writers) {
      const dds_return_t rc = dds_wait_for_acks(w->handle(), DDS_SECS(2));
      if (rc != DDS_RETCODE_TIMEOUT) Check(rc, "dds_wait_for_acks");
    }
    const double until = MonotonicSeconds() + linger;
    while (!StopRequested() && MonotonicSeconds() < until) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    keys.reset();
    spdlog::info("replayed {} samples in {} pass(es), {} refused, latest {:.1f} ms behind", st.samples, st.loops,
                 refused, st.max_lateness_s * 1e3);
    if (rec.damaged_samples() > 0 || refused > 0) {
      spdlog::error("{}: {} damaged sample(s) skipped (CRC-32 mismatch or unknown topic), {} refused by DDS", path,
                    rec.damaged_samples(), refused);
      return 3;
    }
    if (!rec.missing_parts().empty()) {
      spdlog::error("{}: {}: replayed what the other parts hold (exit 3)", path, rec.missing_parts());
      return 3;
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
