// Conversion of a recording between the storages (storage.h), as rosbag2's
// `convert`: every sample copied byte for byte with its topic, QoS, IDL text and
// both timestamps, the meta kept, and the copy read back and compared.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hullpipe/record/recording.h"

namespace hullpipe::record {

/// What Convert copied and found.
struct ConvertReport {
  int64_t topics = 0;
  int64_t samples = 0;          ///< Copied (the input's samples that read).
  int64_t damaged_samples = 0;  ///< Of the input, skipped for a CRC or frame that did not check.
  /// Samples of the output whose topic name, times or bytes differ from the
  /// input's at the same position (CRC-32 of each), or missing or extra: 0 when
  /// the copy is exact.
  int64_t differ = 0;
  std::string input_storage, output_storage;
  std::string input_damage;  ///< RecordingInfo::damage of the input.
  /// Channels not copied: an MCAP file's non-CDR channels (the viewable JSON
  /// ones of `export --foxglove`) have no place in an SQLite recording.
  std::vector<std::string> skipped_topics;
};

/// Copies `in` (a file or split directory, either storage) into the new recording
/// `out` (never overwritten; its storage from `options` or its extension), with
/// meta 'converted_from' added, then reads `out` back and compares every sample's
/// CRC-32 with the input's. Throws RecordingError (files named) or
/// std::invalid_argument (options).
ConvertReport Convert(const std::string& in, const std::string& out, const WriterOptions& options);

}  // namespace hullpipe::record
