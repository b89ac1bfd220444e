// hullpipe_record: records a domain's DDS traffic into one SQLite file (docs/architecture.md).
//   hullpipe_record --domain 7 -o run.hprec [--include 'hullpipe/*'] [--exclude '*/camera_image']
//   hullpipe_record info run.hprec [--json]
// Topics are discovered from the built-in DCPSPublication topic (name, type,
// keyedness, QoS); every topic of a hullpipe type is recorded as serialized CDR
// samples, untouched, with source and arrival timestamps (each pass's samples in
// their writers' source-time order: a take groups them by key). Samples are committed
// in batches (--batch-ms): a recorder killed even by SIGKILL loses at most its
// last batch and the file still opens. SIGINT/SIGTERM stop it cleanly. What the
// readers lost (sample lost / rejected) is counted, logged and stored in meta.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <memory>

#include <CLI/CLI.hpp>
#include <dds/dds.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/record/recording.h"

using namespace hullpipe;
using namespace hullpipe::dds;
using namespace hullpipe::record;

namespace {

int Info(const std::string& path, bool json) {
  const RecordingReader r(path);
  const RecordingInfo info = r.Info();
  if (json) {
    nlohmann::json j;
    j["file"] = path;
    j["duration_s"] = info.duration_s();
    j["samples"] = info.samples;
    j["bytes"] = info.bytes;
    j["meta"] = info.meta;
    j["interrupted"] = info.interrupted;
    j["damage"] = info.damage;
    j["damaged_samples"] = info.damaged_samples;
    for (const auto& t : info.topics)
      j["topics"].push_back({{"name", t.topic.name}, {"type", t.topic.type}, {"count", t.count}, {"bytes", t.bytes},
                             {"keyed", t.topic.keyed}, {"reliable", t.topic.reliable},
                             {"transient_local", t.topic.transient_local}, {"depth", t.topic.depth}});
    std::printf("%s\n", j.dump(1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
    return info.damage.empty() ? 0 : 3;
  }
  std::printf("Files:             %s\n", path.c_str());
  std::printf("Duration:          %.3f s\n", info.duration_s());
  std::printf("Messages:          %lld\n", (long long)info.samples);
  std::printf("Bytes:             %.1f MiB\n", double(info.bytes) / (1 << 20));
  if (info.interrupted)
    std::printf("Interrupted:       yes: the recorder did not close it (killed?); samples up to its last commit\n");
  if (!info.damage.empty()) std::printf("DAMAGED:           %s\n", info.damage.c_str());
  for (const auto& [k, v] : info.meta) std::printf("%-18s %s\n", (k + ":").c_str(), v.c_str());
  std::printf("Topic information:\n");
  for (const auto& t : info.topics)
    std::printf("  %-28s | %-34s | %7lld msgs | %9.1f KiB | %s%s, depth %d\n", t.topic.name.c_str(),
                t.topic.type.c_str(), (long long)t.count, double(t.bytes) / 1024,
                t.topic.reliable ? "reliable" : "best-effort", t.topic.transient_local ? ", transient-local" : "",
                t.topic.depth);
  if (!info.damage.empty()) {
    std::fprintf(stderr, "%s: damaged: %s\n", path.c_str(), info.damage.c_str());
    return 3;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hullpipe_record: record a domain's DDS traffic (serialized) into SQLite"};
  CommonOptions common;
  AddCommonOptions(app, common);
  std::string out;
  std::vector<std::string> include, exclude;
  double duration = 0, batch_ms = 100;
  int depth = 256;
  app.add_option("-o,--output", out, "Recording file to create (never overwritten)");
  app.add_option("--include", include, "Record only topics matching these globs (default: all)");
  app.add_option("--exclude", exclude, "Do not record topics matching these globs");
  app.add_option("--duration", duration, "Stop after this many seconds (0: until SIGINT)");
  app.add_option("--batch-ms", batch_ms, "Commit a batch at least this often, ms")->capture_default_str();
  app.add_option("--depth", depth, "Reader history depth per instance (large: nothing overwritten)")
      ->capture_default_str();
  std::string info_path;
  bool info_json = false;
  auto* info = app.add_subcommand("info", "Topics, types, counts, sizes and duration of a recording");
  info->add_option("file", info_path, "Recording")->required();
  info->add_flag("--json", info_json, "One JSON object");
  CLI11_PARSE(app, argc, argv);
  try {
    if (*info) return Info(info_path, info_json);
    if (out.empty()) throw std::runtime_error("give -o FILE (or the info subcommand)");
    auto participant = StartNode("record", common);
    RecordingWriter rec(out);
    rec.SetMeta("created_ns", std::to_string(NowNs()));
    rec.SetMeta("domain", std::to_string(common.domain));
    WaitSet ws(*participant);
    Entity pubs(Check(dds_create_reader(participant->handle(), DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr),
                      "dds_create_reader(DCPSPublication)"));
    Entity pubs_cond(Check(dds_create_readcondition(pubs.handle(), DDS_ANY_STATE), "dds_create_readcondition"));
    Check(dds_waitset_attach(ws.handle(), pubs_cond.handle(), 0), "dds_waitset_attach");
    struct Recorded {
      int64_t id;
      std::unique_ptr<CdrReader> reader;
      int64_t count = 0;
    };
    std::map<std::string, Recorded> topics;  // by topic name
    std::map<std::string, bool> skipped;
    const double t_start = MonotonicSeconds();
    double last_commit = t_start;
    uint64_t lost_reported = 0;
    auto discover = [&] {
      void* samples[16] = {nullptr};
      dds_sample_info_t si[16];
      for (;;) {
        const int32_t n = Check(dds_take(pubs.handle(), samples, si, 16, 16), "dds_take(DCPSPublication)");
        for (int32_t i = 0; i < n; ++i) {
          if (!si[i].valid_data) continue;
          const auto* ep = static_cast<const dds_builtintopic_endpoint_t*>(samples[i]);
          const std::string name = ep->topic_name ? ep->topic_name : "", type = ep->type_name ? ep->type_name : "";
          if (name.empty() || topics.count(name) || skipped.count(name)) continue;
          if (!TopicSelected(include, exclude, name)) {
            skipped[name] = true;
            continue;
          }
          const KnownType* kt = FindKnownType(type);
          if (!kt || kt->topic_name != name) {
            spdlog::warn("topic {} of type {}: not a hullpipe type; not recorded", name, type);
            skipped[name] = true;
            continue;
          }
          // The writer's QoS, kept for the replay; the recorder's reader takes
          // the same reliability and durability (so it gets transient-local
          // history) with a deep history so nothing is overwritten.
          TopicInfo t;
          t.name = name;
          t.type = type;
          t.keyed = kt->keyed;
          dds_reliability_kind_t rel = DDS_RELIABILITY_RELIABLE;
          dds_duration_t blocking;
          dds_durability_kind_t dur = DDS_DURABILITY_VOLATILE;
          dds_history_kind_t hist = DDS_HISTORY_KEEP_LAST;
          int32_t hdepth = kt->qos.depth;
          if (ep->qos) {
            dds_qget_reliability(ep->qos, &rel, &blocking);
            dds_qget_durability(ep->qos, &dur);
            dds_qget_history(ep->qos, &hist, &hdepth);
          }
          t.reliable = rel == DDS_RELIABILITY_RELIABLE;
          t.transient_local = dur != DDS_DURABILITY_VOLATILE;
          t.depth = hist == DDS_HISTORY_KEEP_LAST ? hdepth : depth;
          Recorded r;
          r.id = rec.AddTopic(t);
          r.reader = std::make_unique<CdrReader>(*participant, *kt, QosSpec{t.reliable, t.transient_local, depth});
          Check(dds_waitset_attach(ws.handle(), r.reader->condition(), 0), "dds_waitset_attach");
          spdlog::info("recording {} ({}{})", name, t.reliable ? "reliable" : "best-effort",
                       t.transient_local ? ", transient-local" : "");
          topics.emplace(name, std::move(r));
        }
        if (n > 0) dds_return_loan(pubs.handle(), samples, n);
        if (n < 16) break;
      }
    };
    // One pass over every topic's reader. A take returns samples grouped by
    // instance (key), not in arrival order: what one pass took is put back in the
    // writers' order (source time) before it is appended.
    auto take_all = [&] {
      std::vector<Sample> taken;
      for (auto& entry : topics) {
        auto& r = entry.second;  // (a structured binding cannot be captured by clang 14's lambdas)
        const auto topic_id = r.id;
        r.count += int64_t(r.reader->TakeEach([&](const std::vector<uint8_t>& bytes, int64_t source_ns) {
          Sample s;
          s.topic_id = topic_id;
          s.source_ns = source_ns;
          s.arrival_ns = NowNs();
          s.data = bytes;
          taken.push_back(std::move(s));
        }));
      }
      std::stable_sort(taken.begin(), taken.end(),
                       [](const Sample& a, const Sample& b) { return a.source_ns < b.source_ns; });
      for (size_t k = 1; k < taken.size(); ++k)  // arrival order = source order within the pass
        taken[k].arrival_ns = std::max(taken[k].arrival_ns, taken[k - 1].arrival_ns);
      for (const Sample& s : taken) rec.Append(s);
    };
    while (!StopRequested() && !(duration > 0 && MonotonicSeconds() - t_start > duration)) {
      ws.Wait(0.05);
      discover();
      take_all();
      if ((MonotonicSeconds() - last_commit) * 1e3 >= batch_ms) {
        rec.Commit();
        last_commit = MonotonicSeconds();
        uint64_t lost = 0;
        for (const auto& [name, r] : topics) lost += r.reader->Lost();
        if (lost > lost_reported) {
          spdlog::warn("{} samples lost before the recorder took them", lost - lost_reported);
          lost_reported = lost;
        }
      }
    }
    // What the readers received (and acknowledged) before the stop is recorded
    // too: one last pass.
    take_all();
    uint64_t lost = 0;
    for (const auto& [name, r] : topics) {
      lost += r.reader->Lost();
      rec.SetMeta("lost:" + name, std::to_string(r.reader->Lost()));
      spdlog::info("{}: {} samples", name, r.count);
    }
    rec.SetMeta("lost_total", std::to_string(lost));
    rec.SetMeta("stopped_ns", std::to_string(NowNs()));
    rec.Commit();
    spdlog::info("stopped: {} samples in {}, {} lost", rec.samples_committed(), out, lost);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
