// `hullpipe_record export --foxglove` (docs/recording.md, "Viewable channels"): an
// MCAP file for people who want to look, not decode — the recording's own
// channels (cdr, omgidl) beside the viewable channels of hullpipe/foxglove/channels.h
// (Foxglove's well-known schemas, JSON-encoded, `jsonschema` schemas), which
// Foxglove and Lichtblick draw in their Image, 3D and Plot panels with no plugin.
// Done at export, not while recording: the recorder keeps the traffic untouched
// and costs nothing extra; the derivation (JPEG, transforms) happens once, later.
// hullpipe_bridge derives the same channels live.
#pragma once

#include <map>
#include <memory>
#include <string>

#include "hullpipe/foxglove/channels.h"
#include "hullpipe/dds/dds.h"
#include "hullpipe/record/recording.h"

namespace hullpipe::record {

/// Writes the viewable MCAP. Not thread-safe.
class FoxgloveExport {
 public:
  /// Creates `path` (MCAP, zstd chunks; never overwritten); `participant`
  /// deserializes samples. Throws RecordingError.
  FoxgloveExport(const std::string& path, const dds::Participant& participant);
  /// A recorded sample: copied untouched on its own channel (topic added once),
  /// then what it derives, logged at its arrival time (their timestamps are the
  /// capture times). False if it does not decode as its type (still copied).
  bool Add(const TopicInfo& topic, const Sample& sample);
  /// Derived messages written, per channel.
  const std::map<std::string, int64_t>& counts() const { return counts_; }
  const std::string& path() const { return path_; }

 private:
  void Write(const foxglove::Message& m);
  void Appended();
  std::string path_;
  RecordingWriter w_;
  foxglove::Deriver deriver_;
  std::map<std::string, int64_t> ids_;  // channel topic -> id
  std::map<std::string, int64_t> counts_;
  int64_t appended_ = 0;
  int64_t log_ns_ = -1;  // the arrival of the raw sample a derived one comes from
};

}  // namespace hullpipe::record
