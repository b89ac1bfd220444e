#include "record_session.h"

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <map>
#include <memory>

#include <dds/dds.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/record/convert.h"
#include "hullpipe/record/repair.h"
#include "hullpipe/util/logging.h"

namespace hullpipe::record {

using namespace hullpipe::dds;

namespace {

// "2026-11-23T05:01:02.345Z" for ns since the Unix epoch.
std::string IsoTime(int64_t ns) {
  if (ns <= 0) return "-";
  const std::time_t secs = std::time_t(ns / 1'000'000'000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[48];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  return fmt::format("{}.{:03d}Z", buf, int((ns / 1'000'000) % 1000));
}

}  // namespace

int Info(const std::string& path, bool json, bool idl) {
  const RecordingReader r(path);
  const RecordingInfo info = r.Info();
  const bool closed = !info.interrupted;
  if (json) {
    nlohmann::json j;
    j["file"] = path;
    j["files"] = info.files;
    j["file_bytes"] = info.file_bytes;
    j["storage"] = info.storage;
    j["format"] = info.format;
    j["serialization"] = "cdr";
    j["compression"] = info.compression;
    j["start"] = IsoTime(info.first_arrival_ns);
    j["end"] = IsoTime(info.last_arrival_ns);
    j["duration_s"] = info.duration_s();
    j["samples"] = info.samples;
    j["bytes"] = info.bytes;
    j["stored_bytes"] = info.stored_bytes;
    j["meta"] = info.meta;
    j["closed_cleanly"] = closed;
    j["interrupted"] = info.interrupted;
    j["damage"] = info.damage;
    j["damaged_samples"] = info.damaged_samples;
    for (const auto& t : info.topics) {
      nlohmann::json tj = {{"name", t.topic.name}, {"type", t.topic.type}, {"count", t.count}, {"bytes", t.bytes},
                           {"stored_bytes", t.stored_bytes}, {"keyed", t.topic.keyed}, {"reliable", t.topic.reliable},
                           {"transient_local", t.topic.transient_local}, {"depth", t.topic.depth}};
      tj["lost"] = t.lost >= 0 ? nlohmann::json(t.lost) : nlohmann::json(nullptr);
      if (idl) tj["type_description"] = t.topic.type_description;
      j["topics"].push_back(tj);
    }
    j["command"] = CommandLine();
    std::printf("%s\n", j.dump(1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
    return info.damage.empty() ? 0 : 3;
  }
  std::printf("Files:             %s", path.c_str());
  if (info.files.size() > 1) std::printf(" (%zu parts)", info.files.size());
  std::printf("\nSize:              %.1f MiB on disk\n", double(info.file_bytes) / (1 << 20));
  std::printf("Storage:           %s%s; serialization cdr; compression %s\n", info.storage.c_str(),
              info.format == info.storage ? "" : (", " + info.format).c_str(), info.compression.c_str());
  std::printf("Start:             %s\n", IsoTime(info.first_arrival_ns).c_str());
  std::printf("End:               %s\n", IsoTime(info.last_arrival_ns).c_str());
  std::printf("Duration:          %.3f s\n", info.duration_s());
  std::printf("Messages:          %lld\n", (long long)info.samples);
  std::printf("Bytes:             %.1f MiB (%.1f MiB stored)\n", double(info.bytes) / (1 << 20),
              double(info.stored_bytes) / (1 << 20));
  std::printf("Closed cleanly:    %s\n",
              closed ? "yes"
                     : "no: the recorder did not close it (killed?); samples up to its last commit "
                       "(`hullpipe_record repair` recovers a file cut short)");
  if (!info.damage.empty()) std::printf("DAMAGED:           %s\n", info.damage.c_str());
  for (const auto& [k, v] : info.meta)
    if (k.rfind("lost:", 0) != 0) std::printf("%-18s %s\n", (k + ":").c_str(), v.c_str());
  std::printf("Topic information:\n");
  for (const auto& t : info.topics) {
    std::printf("  %-28s | %-34s | %7lld msgs | %9.1f KiB | %s%s, depth %d | lost %s\n", t.topic.name.c_str(),
                t.topic.type.c_str(), (long long)t.count, double(t.stored_bytes) / 1024,
                t.topic.reliable ? "reliable" : "best-effort", t.topic.transient_local ? ", transient-local" : "",
                t.topic.depth, t.lost >= 0 ? std::to_string(t.lost).c_str() : "?");
    if (idl) std::printf("%s\n", t.topic.type_description.empty() ? "    (no IDL: recorded before format 3)"
                                                                  : t.topic.type_description.c_str());
  }
  if (!info.damage.empty()) {
    std::fprintf(stderr, "%s: damaged: %s\n", path.c_str(), info.damage.c_str());
    return 3;
  }
  return 0;
}

int ConvertCmd(const std::string& in, const std::string& out, const std::string& storage,
               const std::string& compression, int zstd_level) {
  WriterOptions wo;
  wo.compression = ParseCompression(compression);
  wo.zstd_level = zstd_level;
  if (!storage.empty()) wo.storage = ParseStorage(storage);
  const ConvertReport rep = Convert(in, out, wo);
  for (const auto& t : rep.skipped_topics)
    spdlog::warn("{}: channel {} is not CDR (a viewable channel); SQLite recordings hold CDR only: not copied", in, t);
  if (!rep.input_damage.empty())
    spdlog::warn("{}: damaged ({}); converted what reads ({} samples skipped; `hullpipe_record repair` first keeps "
                 "what a cut file holds)",
                 in, rep.input_damage, rep.damaged_samples);
  spdlog::info("{} ({}) -> {} ({}, compression {}): {} samples of {} topics; every sample's CRC-32 {}", in,
               rep.input_storage, out, rep.output_storage, CompressionName(wo.compression), rep.samples, rep.topics,
               rep.differ ? "DIFFERS" : "equal");
  if (rep.differ) {
    spdlog::error("{}: {} sample(s) differ from {} after the conversion", out, rep.differ, in);
    return 3;
  }
  return rep.input_damage.empty() ? 0 : 3;
}

int RepairCmd(const std::string& in, const std::string& out) {
  const RepairReport rep = Repair(in, out);
  spdlog::info("{} -> {}: {} samples of {} topics recovered ({} pages, {} log frames); {} rows failed their CRC, "
               "{} ran into a missing page, {} belonged to a lost topic; the input was {}",
               in, out, rep.samples, rep.topics, rep.pages, rep.wal_frames, rep.bad_samples, rep.incomplete_samples,
               rep.orphan_samples, rep.was_closed ? "closed" : "not closed (interrupted)");
  if (rep.topics == 0) {
    spdlog::error("{}: no topic recovered; {} holds nothing to replay", in, out);
    return 3;
  }
  return 0;
}

namespace {

volatile std::sig_atomic_t g_snapshot_signals = 0;
void OnSigusr1(int) { g_snapshot_signals = g_snapshot_signals + 1; }

// Where recorded samples go: one file, a split recording, or the snapshot window.
class Output {
 public:
  virtual ~Output() = default;
  virtual int64_t AddTopic(const TopicInfo& t) = 0;
  virtual void Append(const Sample& s) = 0;
  virtual void Commit() = 0;
  virtual void SetMeta(const std::string& k, const std::string& v) = 0;
  virtual int64_t samples_committed() const = 0;
};

template <typename W>
class WriterOutput : public Output {
 public:
  template <typename... A>
  explicit WriterOutput(A&&... a) : w_(std::forward<A>(a)...) {}
  int64_t AddTopic(const TopicInfo& t) override { return w_.AddTopic(t); }
  void Append(const Sample& s) override { w_.Append(s); }
  void Commit() override { w_.Commit(); }
  void SetMeta(const std::string& k, const std::string& v) override { w_.SetMeta(k, v); }
  int64_t samples_committed() const override { return w_.samples_committed(); }

 private:
  W w_;
};

// Snapshot mode: the window in memory; Write() puts it in DIR/snapshot_NNNN.hprec.
class SnapshotOutput : public Output {
 public:
  SnapshotOutput(const std::string& dir, const SnapshotOptions& o, const WriterOptions& w)
      : dir_(dir), buffer_(o), writer_options_(w) {
    std::error_code ec;
    std::filesystem::create_directories(dir_, ec);
    if (ec || !std::filesystem::is_directory(dir_)) throw RecordingError(dir_ + ": cannot create the directory");
  }
  int64_t AddTopic(const TopicInfo& t) override {
    TopicInfo mine = t;
    mine.id = int64_t(buffer_.topics().size()) + 1;  // the ids a new file gives, in this order
    buffer_.AddTopic(mine);
    return mine.id;
  }
  void Append(const Sample& s) override { buffer_.Add(s); }
  void Commit() override {}
  void SetMeta(const std::string& k, const std::string& v) override { meta_[k] = v; }
  int64_t samples_committed() const override { return written_; }
  // Writes the last seconds before now; returns the file.
  std::string Write(const std::string& trigger) {
    const int64_t now = NowNs();  // the window ends here, as snapshot_ns says
    buffer_.TrimTo(now);
    std::string path;
    for (;;) {  // never overwrite: the next free number
      path = (std::filesystem::path(dir_) /
              fmt::format("snapshot_{:04d}{}", ++count_,
                          StorageExtension(writer_options_.storage.value_or(StorageForPath(dir_)))))
                 .string();
      if (!std::filesystem::exists(path)) break;
    }
    const auto samples = buffer_.Contents();
    RecordingWriter w(path, writer_options_);
    for (const auto& [k, v] : meta_) w.SetMeta(k, v);
    w.SetMeta("snapshot_trigger", trigger);
    w.SetMeta("snapshot_ns", std::to_string(now));
    for (const auto& t : buffer_.topics()) w.AddTopic(t);
    for (const auto& s : samples) w.Append(s);
    w.Commit();
    written_ += int64_t(samples.size());
    spdlog::info("snapshot ({}): {} samples, {:.1f} MiB, {:.2f} s, in {}", trigger, samples.size(),
                 double(buffer_.bytes()) / (1 << 20),
                 samples.empty() ? 0.0 : double(samples.back().arrival_ns - samples.front().arrival_ns) * 1e-9, path);
    return path;
  }

 private:
  std::string dir_;
  SnapshotBuffer buffer_;
  WriterOptions writer_options_;
  std::map<std::string, std::string> meta_;
  int count_ = 0;
  int64_t written_ = 0;
};

}  // namespace

int RunRecord(const RecordOptions& o) {
  WriterOptions wo = o.writer;
  SplitOptions so = o.split;
  SnapshotOptions snap = o.snapshot;
  if (o.out.empty()) throw std::runtime_error("give -o FILE (or the info, repair or export subcommand)");
  wo.compression = ParseCompression(o.compression);
  if (!o.storage.empty()) wo.storage = ParseStorage(o.storage);
  const bool split_or_snapshot = so.max_bytes > 0 || so.max_duration_s > 0 || snap.seconds != 0 ||
                                 o.snapshot_bytes_given;
  if (!split_or_snapshot) wo.Check(wo.storage.value_or(StorageForPath(o.out)));
  so.writer = wo;
  so.Check();
  // --snapshot-bytes alone: a window by size (as long as an hour of traffic).
  if (o.snapshot_bytes_given && snap.seconds == 0) snap.seconds = 3600;
  const bool split = so.max_bytes > 0 || so.max_duration_s > 0, snapshot = snap.seconds != 0;
  if (split && snapshot) throw std::invalid_argument("--snapshot-seconds goes without --split-size/--split-duration");
  if (snapshot) snap.Check();
  std::unique_ptr<Output> rec;
  SnapshotOutput* snapshots = nullptr;
  // SIGUSR1 writes a snapshot; outside snapshot mode it is logged and ignored
  // (its default action would end the recorder without closing the file).
  std::signal(SIGUSR1, OnSigusr1);
  if (snapshot) {
    auto snapshot_output = std::make_unique<SnapshotOutput>(o.out, snap, wo);
    snapshots = snapshot_output.get();
    rec = std::move(snapshot_output);
  } else if (split) {
    rec = std::make_unique<WriterOutput<SplitWriter>>(o.out, so);
  } else {
    rec = std::make_unique<WriterOutput<RecordingWriter>>(o.out, wo);
  }
  auto participant = StartNode("record", o.common);
  rec->SetMeta("created_ns", std::to_string(NowNs()));
  rec->SetMeta("domain", std::to_string(o.common.domain));
  // Snapshot commands from the domain (hullpipe_cmd snapshot).
  std::unique_ptr<Reader<hullpipe_msg_RecordCommand>> commands;
  if (snapshots) commands = std::make_unique<Reader<hullpipe_msg_RecordCommand>>(*participant);
  int snapshot_signals_seen = 0;
  WaitSet ws(*participant);
  if (commands) Check(dds_waitset_attach(ws.handle(), commands->condition(), 0), "dds_waitset_attach");
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
        if (!TopicSelected(o.include, o.exclude, name)) {
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
        t.type_description = IdlText();
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
        t.depth = hist == DDS_HISTORY_KEEP_LAST ? hdepth : o.depth;
        Recorded r;
        r.id = rec->AddTopic(t);
        r.reader = std::make_unique<CdrReader>(*participant, *kt, QosSpec{t.reliable, t.transient_local, o.depth});
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
    for (const Sample& s : taken) rec->Append(s);
  };
  while (!StopRequested() && !(o.duration > 0 && MonotonicSeconds() - t_start > o.duration)) {
    ws.Wait(0.05);
    discover();
    take_all();
    if (!snapshots && g_snapshot_signals != snapshot_signals_seen) {
      snapshot_signals_seen = g_snapshot_signals;
      spdlog::warn("SIGUSR1 ignored: it writes a snapshot in snapshot mode (--snapshot-seconds) only");
    }
    if (snapshots) {
      std::string trigger;
      if (g_snapshot_signals != snapshot_signals_seen) {
        snapshot_signals_seen = g_snapshot_signals;
        trigger = "SIGUSR1";
      }
      commands->TakeEach([&](const hullpipe_msg_RecordCommand& c, const dds_sample_info_t&) {
        if (c.command == hullpipe_msg_RECORD_COMMAND_SNAPSHOT) trigger = "command";
      });
      if (!trigger.empty()) snapshots->Write(trigger);
    }
    if ((MonotonicSeconds() - last_commit) * 1e3 >= o.batch_ms) {
      rec->Commit();
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
    rec->SetMeta("lost:" + name, std::to_string(r.reader->Lost()));
    spdlog::info("{}: {} samples", name, r.count);
  }
  rec->SetMeta("lost_total", std::to_string(lost));
  rec->SetMeta("stopped_ns", std::to_string(NowNs()));
  rec->Commit();
  spdlog::info("stopped: {} samples {} {}, {} lost", rec->samples_committed(),
               snapshots ? "written in snapshots to" : "in", o.out, lost);
  return 0;
}

}  // namespace hullpipe::record
