// A recording split by size or duration into a numbered set of files read as one
// (docs/recording.md): DIR/part_0000.hprec, part_0001.hprec, ... (.mcap where the
// options' storage, or DIR's own extension, says MCAP) each a complete
// recording (recording.h) with meta 'set' (one random id for the whole set) and
// 'part' (its index). RecordingReader(DIR) reads them as one recording.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "hullpipe/record/recording.h"

namespace hullpipe::record {

/// Settings of SplitWriter.
struct SplitOptions {
  /// Start a new part once the current one holds this many stored sample bytes
  /// (0: no limit by size). Checked before each sample, so a part ends at most one
  /// sample above it.
  int64_t max_bytes = 0;
  /// Start a new part once the current one spans this many seconds of arrival
  /// time (0: no limit by duration).
  double max_duration_s = 0;
  WriterOptions writer;
  /// Bounds: max_bytes 0 or >= 4096 (a part must hold something); max_duration_s 0
  /// or in [0.1, 1e6]. Throws std::invalid_argument naming the flag (--split-size,
  /// --split-duration).
  void Check() const;
};

/// Writes a split recording into a new directory. Not thread-safe. Every part
/// starts with every topic added so far (same ids) and every meta value set so
/// far, so each part replays alone too (transient-local samples aside).
class SplitWriter {
 public:
  /// Creates directory `dir` (an existing one is an error: recordings are never
  /// overwritten) and its first part. Throws RecordingError or
  /// std::invalid_argument (options).
  SplitWriter(const std::string& dir, const SplitOptions& options);
  /// Closes the current part (RecordingWriter's destructor).
  ~SplitWriter();
  SplitWriter(const SplitWriter&) = delete;
  SplitWriter& operator=(const SplitWriter&) = delete;

  /// As RecordingWriter: the same id in every part.
  int64_t AddTopic(const TopicInfo& topic);
  /// Appends to the current part, first starting the next part if the current one
  /// is full (size or duration). Throws RecordingError.
  void Append(const Sample& sample);
  void Commit();
  /// Sets a meta value in the current part and every later one.
  void SetMeta(const std::string& key, const std::string& value);
  int parts() const { return index_ + 1; }
  int64_t samples_committed() const { return committed_before_ + (part_ ? part_->samples_committed() : 0); }
  int64_t stored_bytes() const { return stored_before_ + part_->stored_bytes(); }
  int64_t raw_bytes() const { return raw_before_ + part_->raw_bytes(); }
  /// The path of part `index` in `dir`, with the extension of `storage`.
  static std::string PartPath(const std::string& dir, int index, Storage storage = Storage::kSqlite);

 private:
  void NextPart();
  std::string dir_;
  SplitOptions options_;
  std::string set_id_;
  int index_ = -1;
  std::unique_ptr<RecordingWriter> part_;
  std::vector<TopicInfo> topics_;
  std::map<std::string, std::string> meta_;
  int64_t part_first_arrival_ns_ = -1;
  int64_t committed_before_ = 0, stored_before_ = 0, raw_before_ = 0;
};

}  // namespace hullpipe::record
