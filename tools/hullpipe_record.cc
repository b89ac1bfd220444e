// hullpipe_record: records a domain's DDS traffic into SQLite or MCAP (docs/recording.md).
//   hullpipe_record --domain 7 -o run.hprec [--include 'hullpipe/*'] [--exclude '*/camera_image']
//                   [--compression zstd] [--split-size 500MB | --split-duration 60]  (-o: a directory)
//   hullpipe_record --domain 7 -o run.mcap [--compression zstd|lz4|none]   (MCAP, by the extension)
//   hullpipe_record convert run.hprec -o run.mcap                (either way, byte for byte)
//   hullpipe_record --domain 7 -o snaps --snapshot-seconds 10     (writes on SIGUSR1 or
//                                                                 `hullpipe_cmd snapshot`)
//   hullpipe_record info run.hprec [--json] [--idl]
//   hullpipe_record repair broken.hprec -o fixed.hprec
//   hullpipe_record export run.hprec -o DIR [--topic GLOB] [--start S] [--end S]
//   hullpipe_record echo run.hprec [--topic GLOB] [--start S] [--end S]     (JSON lines on stdout)
// Topics are discovered from the built-in DCPSPublication topic (name, type,
// keyedness, QoS); every topic of a hullpipe type is recorded as serialized CDR
// samples, untouched, with source and arrival timestamps (each pass's samples in
// their writers' source-time order: a take groups them by key) and the IDL text of
// its type. Samples are committed in batches (--batch-ms): a recorder killed even
// by SIGKILL loses at most its last batch and the file still opens (`repair`
// recovers a file cut short). SIGINT/SIGTERM stop it cleanly. What the readers
// lost (sample lost / rejected) is counted, logged and stored in meta per topic.
#include <cstdio>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "hullpipe/dds/node.h"
#include "hullpipe/util/logging.h"
#include "record_export.h"
#include "record_session.h"

using namespace hullpipe;
using namespace hullpipe::dds;
using namespace hullpipe::record;

int main(int argc, char** argv) {
  CLI::App app{"hullpipe_record: record a domain's DDS traffic (serialized) into SQLite or MCAP"};
  RecordOptions ro;
  const CommonOptions& common = ro.common;
  OpenCommandLine(argc, argv, "hullpipe_record", app, ro.common);
  ro.snapshot.seconds = 0;
  app.add_option("-o,--output", ro.out,
                 "Recording to create (never overwritten): a file, or a directory with --split-* and --snapshot-*");
  app.add_option("--storage", ro.storage, "sqlite or mcap (default: by -o's extension, .mcap is MCAP)");
  app.add_option("--compression", ro.compression, "Sample compression: none or zstd (MCAP chunks: also lz4)")
      ->capture_default_str();
  app.add_option("--chunk-size", ro.writer.mcap.chunk_bytes, "MCAP: close a chunk at this size (e.g. 4MiB)")
      ->transform(CLI::AsSizeValue(true))
      ->capture_default_str();
  app.add_option("--zstd-level", ro.writer.zstd_level, "zstd level, 1 (fast) to 19 (small)")->capture_default_str();
  app.add_option("--split-size", ro.split.max_bytes, "Start a new part at this size (e.g. 500MB, 1GiB; 0: never)")
      ->transform(CLI::AsSizeValue(true));
  app.add_option("--split-duration", ro.split.max_duration_s, "Start a new part every this many seconds (0: never)");
  app.add_option("--snapshot-seconds", ro.snapshot.seconds,
                 "Snapshot mode: keep the last S seconds in memory; write them on SIGUSR1 or `hullpipe_cmd snapshot`");
  auto* snapshot_bytes =
      app.add_option("--snapshot-bytes", ro.snapshot.max_bytes,
                     "Snapshot mode: at most this much in memory (e.g. 2GiB); alone: the last this-many bytes")
          ->transform(CLI::AsSizeValue(true))
          ->capture_default_str();
  app.add_option("--include", ro.include, "Record only topics matching these globs (default: all)");
  app.add_option("--exclude", ro.exclude, "Do not record topics matching these globs");
  app.add_option("--duration", ro.duration, "Stop after this many seconds (0: until SIGINT)");
  app.add_option("--batch-ms", ro.batch_ms, "Commit a batch at least this often, ms")->capture_default_str();
  app.add_option("--depth", ro.depth, "Reader history depth per instance (large: nothing overwritten)")
      ->capture_default_str();
  std::string info_path;
  bool info_json = false, info_idl = false;
  auto* info = app.add_subcommand("info", "Dates, size, format, topics, types, counts, losses of a recording (never "
                                          "modifies it)");
  info->add_option("recording", info_path, "Recording (file or split directory)")->required();
  info->add_flag("--json", info_json, "One JSON object");
  info->add_flag("--idl", info_idl, "Print each topic's IDL text as recorded");
  std::string repair_in, repair_out;
  auto* repair =
      app.add_subcommand("repair", "Recover what a killed recorder or a cut file holds into a new recording");
  repair->add_option("file", repair_in, "Damaged recording (its -wal beside it is read too)")->required();
  repair->add_option("-o,--output", repair_out, "New recording (never overwritten)")->required();
  std::string convert_in, convert_out, convert_storage, convert_compression = "none";
  int convert_level = 1;
  auto* convert = app.add_subcommand("convert", "Copy a recording into the other storage (SQLite <-> MCAP), every "
                                                "sample byte for byte, checked by CRC-32");
  convert->add_option("recording", convert_in, "Recording (file or split directory, either storage)")->required();
  convert->add_option("-o,--output", convert_out, "New recording (never overwritten); .mcap is MCAP")->required();
  convert->add_option("--storage", convert_storage, "sqlite or mcap (default: by -o's extension)");
  convert->add_option("--compression", convert_compression, "none, zstd or lz4 (MCAP only)")->capture_default_str();
  convert->add_option("--zstd-level", convert_level, "zstd level, 1 (fast) to 19 (small)")->capture_default_str();
  ExportOptions eo;
  auto* exp = app.add_subcommand("export", "Maps as PNG, images and hull views as video, reports and stats as "
                                           "CSV, any topic as JSON lines");
  AddExportOptions(exp, eo);
  ExportOptions echo_options;
  echo_options.echo = true;
  echo_options.media = false;
  auto* echo = app.add_subcommand("echo", "Every selected sample as one JSON line on stdout");
  AddExportOptions(echo, echo_options, true);
  CLI11_PARSE(app, argc, argv);
  try {
    if (*info) return Info(info_path, info_json, info_idl);
    if (*repair) return RepairCmd(repair_in, repair_out);
    if (*convert) return ConvertCmd(convert_in, convert_out, convert_storage, convert_compression, convert_level);
    if (*exp) return Export(eo, common);
    if (*echo) {
      spdlog::set_default_logger(spdlog::stderr_color_mt("echo"));  // stdout carries the samples,
      std::setvbuf(stdout, nullptr, _IOLBF, 0);                      // whole lines at a time
      return Export(echo_options, common);
    }
    ro.snapshot_bytes_given = snapshot_bytes->count() > 0;
    return RunRecord(ro);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
