// record_bench: the recorder's storage throughput (docs/benchmarks.md, "Recording
// throughput"): RecordingWriter in each storage (SQLite, MCAP) with and without
// compression at 1 MiB samples and at the rig's traffic (a recording's samples
// written again), against this disk's own sequential write rate; compression
// ratio and CPU per topic. No DDS: what the storage costs, apart from transport.
//   record_bench --dir /tmp --recording run.hprec [--mib 512]
// With --publish N: publishes N 1-MiB camera images of four cameras on --domain,
// each frameset acknowledged before the next (lossless), for a running hullpipe_record to take
// (scripts/record_bench.sh runs the recorder and reads its info).
//   record_bench --publish 512 --domain 7
#include <fcntl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <random>

#include <CLI/CLI.hpp>
#include <zstd.h>

#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/record/recording.h"
#include "hullpipe/util/logging.h"

using namespace hullpipe::record;

namespace {

double Now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
double CpuSeconds() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return double(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) + 1e-6 * double(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}
int64_t FileBytes(const std::string& p) {
  std::error_code ec;
  int64_t n = 0;
  for (const auto& f : {p, p + "-wal"}) {
    const auto s = std::filesystem::file_size(f, ec);
    if (!ec) n += int64_t(s);
  }
  return n;
}

struct Row {
  std::string what;
  double mb = 0, seconds = 0, cpu = 0;
  int64_t file_bytes = 0;
};

void Print(const Row& r) {
  std::printf("| %-44s | %8.0f | %8.1f | %9.2f | %8.3f |\n", r.what.c_str(), r.mb / r.seconds, r.cpu / r.seconds,
              r.cpu / (r.mb / 1024.0), r.file_bytes > 0 ? double(r.file_bytes) / (r.mb * 1e6) : 0.0);
}

// The disk: `mib` MiB in 1 MiB writes, then fdatasync, the time of both.
Row Disk(const std::string& dir, int mib) {
  const std::string path = dir + "/record_bench_disk.bin";
  std::vector<char> buf(1 << 20);
  std::mt19937 rng(1);
  for (auto& c : buf) c = char(rng());
  const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0) throw std::runtime_error(path + ": cannot create");
  const double t0 = Now(), c0 = CpuSeconds();
  for (int i = 0; i < mib; ++i)
    if (write(fd, buf.data(), buf.size()) != ssize_t(buf.size())) throw std::runtime_error(path + ": write failed");
  fdatasync(fd);
  const double t1 = Now(), c1 = CpuSeconds();
  close(fd);
  std::filesystem::remove(path);
  return {"disk: write() 1 MiB blocks + fdatasync", mib * 1.048576, t1 - t0, c1 - c0, 0};
}

// RecordingWriter: `samples` written, committed every `batch`; the file's close
// (commit and WAL checkpoint) is timed too.
Row Write(const std::string& dir, const std::string& what, const std::vector<Sample>& samples,
          const std::vector<TopicInfo>& topics, Compression c, int level, int batch, Storage storage) {
  const std::string path = dir + "/record_bench" + StorageExtension(storage);
  std::filesystem::remove(path);
  double mb = 0;
  for (const auto& s : samples) mb += double(s.data.size()) / 1e6;
  const double t0 = Now(), c0 = CpuSeconds();
  {
    WriterOptions o;
    o.compression = c;
    o.zstd_level = level;
    o.storage = storage;
    RecordingWriter w(path, o);
    for (const auto& t : topics) w.AddTopic(t);
    int n = 0;
    for (const auto& s : samples) {
      w.Append(s);
      if (++n % batch == 0) w.Commit();
    }
  }
  const double t1 = Now(), c1 = CpuSeconds();
  Row r{what, mb, t1 - t0, c1 - c0, FileBytes(path)};
  std::filesystem::remove(path);
  return r;
}

// Publishes n 1-MiB BGR images (604x579), each acknowledged before the next.
int Publish(int n, uint32_t domain) {
  hullpipe::dds::CommonOptions common;
  common.domain = domain;
  auto participant = hullpipe::dds::StartNode("record_bench", common);
  hullpipe::dds::Writer<hullpipe_msg_CameraImage> writer(*participant);
  const double until = Now() + 20;
  while (writer.MatchedReaders() == 0 && Now() < until) usleep(20'000);
  if (writer.MatchedReaders() == 0) {
    std::fprintf(stderr, "record_bench --publish: no reader (start hullpipe_record first)\n");
    return 1;
  }
  usleep(500'000);  // the recorder's reader has matched us too
  cv::Mat img(579, 604, CV_8UC3);
  cv::randu(img, 0, 256);
  const double t0 = Now();
  // Four cameras (instances), as the rig; every 4th sample waits for the
  // acknowledgements, so at most a frameset is in flight (the writer keeps the
  // last 4 per camera: nothing is overwritten before the recorder has it).
  for (int i = 0; i < n && !hullpipe::dds::StopRequested(); ++i) {
    img.at<cv::Vec3b>(0, 0)[0] = uint8_t(i);
    writer.Write(
        hullpipe::dds::MakeImageMessage(uint32_t(i % 4 + 1), uint64_t(i / 4 + 1), hullpipe::NowNs(), img, 0).msg);
    if (i % 4 == 3 || i == n - 1)
      hullpipe::dds::Check(dds_wait_for_acks(writer.handle(), DDS_SECS(10)), "dds_wait_for_acks");
  }
  const double t1 = Now();
  const double mb = double(n) * double(img.total() * 3) / 1e6;
  std::printf("published %d samples of %.3f MB in %.2f s: %.0f MB/s acknowledged\n", n,
              double(img.total() * 3) / 1e6, t1 - t0, mb / (t1 - t0));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  hullpipe::LogToStderr("record_bench");  // stdout carries only what a user asked for
  hullpipe::SetCommandLine(argc, argv);
  CLI::App app{"record_bench: recording storage throughput against the disk"};
  std::string dir = "/tmp", recording;
  int mib = 512, repeats = 3;
  app.add_option("--dir", dir, "Where to write (the disk measured)")->capture_default_str();
  app.add_option("--recording", recording, "A recording of the rig (its samples are written again)");
  app.add_option("--mib", mib, "MiB per 1 MiB-sample row")->capture_default_str();
  app.add_option("--repeats", repeats, "Runs per row (median)")->capture_default_str();
  int publish = 0;
  uint32_t domain = 0;
  app.add_option("--publish", publish, "Publish this many 1-MiB images for a running recorder instead");
  app.add_option("--domain", domain, "DDS domain for --publish");
  CLI11_PARSE(app, argc, argv);
  if (publish > 0) return Publish(publish, domain);
  auto median = [&](const std::function<Row()>& f) {
    std::vector<Row> rows;
    for (int i = 0; i < repeats; ++i) rows.push_back(f());
    std::sort(rows.begin(), rows.end(), [](const Row& a, const Row& b) { return a.mb / a.seconds < b.mb / b.seconds; });
    return rows[rows.size() / 2];
  };
  std::printf("record_bench: %s, median of %d\n\n", dir.c_str(), repeats);
  std::printf("| %-44s | %8s | %8s | %9s | %8s |\n", "row", "MB/s", "CPU/s", "CPU s/GiB", "file/raw");
  std::printf("|%s|%s|%s|%s|%s|\n", std::string(46, '-').c_str(), std::string(10, '-').c_str(),
              std::string(10, '-').c_str(), std::string(11, '-').c_str(), std::string(10, '-').c_str());
  Print(median([&] { return Disk(dir, mib); }));
  // 1 MiB samples: random bytes (incompressible), and the rig's camera images
  // where a recording is given (else a smooth gradient).
  const TopicInfo topic{1, "bench/blob", "hullpipe::msg::CameraImage", true, true, false, 4, ""};
  std::vector<Sample> random(static_cast<size_t>(mib)), smooth(static_cast<size_t>(mib));
  std::mt19937 rng(2);
  for (int i = 0; i < mib; ++i) {
    random[size_t(i)] = {1, i, int64_t(i) * 1'000'000, std::vector<uint8_t>(1 << 20)};
    for (auto& b : random[size_t(i)].data) b = uint8_t(rng());
    smooth[size_t(i)] = {1, i, int64_t(i) * 1'000'000, std::vector<uint8_t>(1 << 20)};
    for (size_t k = 0; k < smooth[size_t(i)].data.size(); ++k) smooth[size_t(i)].data[k] = uint8_t((k / 3 + i) >> 6);
  }
  // Each storage, each compression it has (a commit every 16 samples: an MCAP
  // chunk of 16 MiB).
  struct Variant {
    const char* name;
    Storage storage;
    Compression c;
  };
  const Variant variants[] = {{"sqlite, none", Storage::kSqlite, Compression::kNone},
                              {"sqlite, zstd 1", Storage::kSqlite, Compression::kZstd},
                              {"mcap, none", Storage::kMcap, Compression::kNone},
                              {"mcap, zstd 1", Storage::kMcap, Compression::kZstd},
                              {"mcap, lz4", Storage::kMcap, Compression::kLz4}};
  for (const auto& data : {std::pair{"1 MiB random", &random}, {"1 MiB smooth", &smooth}})
    for (const auto& v : variants)
      Print(median([&] {
        return Write(dir, std::string(data.first) + ", " + v.name, *data.second, {topic}, v.c, 1, 16, v.storage);
      }));
  random.clear();
  smooth.clear();
  if (recording.empty()) return 0;
  // The rig's traffic, as recorded.
  const RecordingReader rec(recording);
  std::vector<Sample> traffic;
  rec.ForEach([&](const Sample& s) {
    traffic.push_back(s);
    return true;
  });
  const double span = traffic.empty() ? 0 : double(traffic.back().arrival_ns - traffic.front().arrival_ns) * 1e-9;
  double mb = 0;
  for (const auto& s : traffic) mb += double(s.data.size()) / 1e6;
  std::printf("\nrig traffic: %s, %zu samples, %.1f MB in %.1f s (%.1f MB/s live)\n\n", recording.c_str(),
              traffic.size(), mb, span, span > 0 ? mb / span : 0);
  std::printf("| %-44s | %8s | %8s | %9s | %8s |\n", "row", "MB/s", "CPU/s", "CPU s/GiB", "file/raw");
  std::printf("|%s|%s|%s|%s|%s|\n", std::string(46, '-').c_str(), std::string(10, '-').c_str(),
              std::string(10, '-').c_str(), std::string(11, '-').c_str(), std::string(10, '-').c_str());
  for (const auto& v : variants)
    Print(median([&] {
      return Write(dir, std::string("rig traffic, ") + v.name, traffic, rec.topics(), v.c, 1, 64, v.storage);
    }));
  Print(median([&] {
    return Write(dir, "rig traffic, sqlite, zstd 3", traffic, rec.topics(), Compression::kZstd, 3, 64,
                 Storage::kSqlite);
  }));
  // Per topic: zstd 1's ratio and CPU.
  std::printf("\n| %-28s | %8s | %10s | %7s | %12s |\n", "topic (zstd 1)", "samples", "MB", "ratio", "ms CPU / MB");
  std::printf("|%s|%s|%s|%s|%s|\n", std::string(30, '-').c_str(), std::string(10, '-').c_str(),
              std::string(12, '-').c_str(), std::string(9, '-').c_str(), std::string(14, '-').c_str());
  std::map<int64_t, std::string> names;
  for (const auto& t : rec.topics()) names[t.id] = t.name;
  struct PerTopic {
    int64_t n = 0;
    double raw = 0, packed = 0, cpu = 0;
  };
  std::map<std::string, PerTopic> per;
  ZSTD_CCtx* cx = ZSTD_createCCtx();
  std::vector<uint8_t> out;
  for (const auto& s : traffic) {
    auto& p = per[names[s.topic_id]];
    out.resize(ZSTD_compressBound(s.data.size()));
    const double c0 = CpuSeconds();
    const size_t n = ZSTD_compressCCtx(cx, out.data(), out.size(), s.data.data(), s.data.size(), 1);
    p.cpu += CpuSeconds() - c0;
    ++p.n;
    p.raw += double(s.data.size());
    p.packed += double(ZSTD_isError(n) ? s.data.size() : std::min(n, s.data.size()));
  }
  ZSTD_freeCCtx(cx);
  for (const auto& [name, p] : per)
    std::printf("| %-28s | %8lld | %10.2f | %7.2f | %12.2f |\n", name.c_str(), (long long)p.n, p.raw / 1e6,
                p.packed > 0 ? p.raw / p.packed : 0.0, p.raw > 0 ? p.cpu * 1e3 / (p.raw / 1e6) : 0.0);
  return 0;
}
