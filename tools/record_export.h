// `hullpipe_record export` (docs/recording.md): a recording's samples as files people
// look at — maps as PNG, colour images and hull views as video, collision
// reports and node stats as CSV, every selected topic as JSON lines (echo-style).
#pragma once

#include <map>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "hullpipe/dds/node.h"

namespace hullpipe::record {

struct ExportOptions {
  std::string recording;             ///< File or split directory.
  std::string out;                   ///< Directory to create (never overwritten); empty: echo.
  bool echo = false;                 ///< JSON lines of every selected sample on stdout, no files.
  std::vector<std::string> topics;   ///< Globs; none: every topic.
  double start_s = 0, end_s = 0;     ///< Seconds after the recording's start; end 0: its end.
  bool jsonl = true, media = true;   ///< JSON lines; PNG/video/CSV.
  double video_fps = 50;             ///< Frame rate written into the videos.
  /// Also out/foxglove.mcap: the selected channels and viewable ones in
  /// Foxglove's schemas (record_foxglove.h).
  bool foxglove = false;
  /// Also out/ros2.mcap: the cameras, maps and frames as ROS 2 topics, as
  /// rosbag2 writes MCAP (record_ros2.h, docs/ros2.md).
  bool ros2 = false;
};

/// --topic, --start, --end, --no-jsonl, --no-media, --fps, --foxglove and the positionals;
/// with echo, only the recording and the filters.
void AddExportOptions(CLI::App* sub, ExportOptions& o, bool echo = false);

/// Writes the export and `out/export.json` (what was written per topic: samples,
/// PNGs, video frames, CSV rows, JSON lines); with o.echo, the JSON lines to
/// stdout (`hullpipe_record echo`) and the counts to the log. Decoding needs a DDS participant (a
/// writer's sertype); it joins `common.domain` but publishes nothing. Returns the
/// exit code: 0, 3 if some samples did not decode (counted, each topic named once).
int Export(const ExportOptions& o, const dds::CommonOptions& common);

}  // namespace hullpipe::record
