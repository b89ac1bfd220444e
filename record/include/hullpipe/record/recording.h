// Recordings of DDS traffic (docs/architecture.md): serialized samples (CDR, untouched, with
// their encapsulation header) of every recorded topic, with source and arrival
// timestamps, in one SQLite file. DDS-free: the recorder and the player tools put
// DDS on either side; tests use this library alone.
//
// File format (SQLite 3, WAL journal):
//   meta(key TEXT PRIMARY KEY, value TEXT)            format, created_ns, dropped counts...
//   topics(id INTEGER PRIMARY KEY, name TEXT UNIQUE, type TEXT, keyed INTEGER,
//          reliable INTEGER, transient_local INTEGER, depth INTEGER)
//   samples(id INTEGER PRIMARY KEY, topic_id INTEGER, source_ns INTEGER,
//           arrival_ns INTEGER, data BLOB, crc INTEGER) in arrival order
// format 'hullpipe-recording-2'; crc is the CRC-32 (zlib) of topic_id, source_ns,
// arrival_ns (8 bytes each, little-endian) and data. Files of
// format 1 (no crc column) are still read, without the per-sample check.
// Samples are written in batched transactions: a writer killed (even by SIGKILL)
// loses at most its last, uncommitted batch, and the file still opens. A writer
// that closes sets meta 'closed_ns'; a file without it was interrupted.
// Readers open the file read-only: reading never changes it.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

struct sqlite3;
struct sqlite3_stmt;

namespace hullpipe::record {

/// A recorded topic with the QoS its writer had (replayed with the same).
struct TopicInfo {
  int64_t id = 0;             ///< Set by the recording.
  std::string name;           ///< e.g. "hullpipe/camera_info".
  std::string type;           ///< e.g. "hullpipe::msg::CameraInfo".
  bool keyed = false;
  bool reliable = true;
  bool transient_local = false;
  int32_t depth = 1;          ///< Keep-last depth.
};

/// One recorded sample.
struct Sample {
  int64_t topic_id = 0;
  int64_t source_ns = 0;      ///< The writer's source timestamp (CLOCK_REALTIME ns).
  int64_t arrival_ns = 0;     ///< When the recorder took it (CLOCK_REALTIME ns).
  std::vector<uint8_t> data;  ///< Serialized sample, CDR with its 4-byte header.
};

/// The SQLite error policy: every failing call throws this, naming the call and
/// the file.
class RecordingError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Appends to a new recording. Not thread-safe.
class RecordingWriter {
 public:
  /// Creates `path` (an existing file is an error: recordings are never
  /// overwritten). Throws RecordingError.
  explicit RecordingWriter(const std::string& path);
  ~RecordingWriter();  ///< Sets meta 'closed_ns' and commits the open batch.
  RecordingWriter(const RecordingWriter&) = delete;
  RecordingWriter& operator=(const RecordingWriter&) = delete;

  /// Adds a topic; returns its id (the same id if the name is already there).
  int64_t AddTopic(const TopicInfo& topic);
  /// Appends a sample to the open batch (a transaction opened on demand).
  void Append(const Sample& sample);
  /// Commits the open batch: after this returns, the samples survive a crash.
  void Commit();
  /// Sets a meta value (committed with the next batch).
  void SetMeta(const std::string& key, const std::string& value);
  int64_t samples_committed() const { return committed_; }
  int64_t samples_pending() const { return pending_; }

 private:
  void Begin();
  std::string path_;
  sqlite3* db_ = nullptr;
  sqlite3_stmt* insert_ = nullptr;
  bool in_txn_ = false;
  int64_t committed_ = 0, pending_ = 0;
};

/// Summary of a recording (`hullpipe_record info`).
struct RecordingInfo {
  struct TopicSummary {
    TopicInfo topic;
    int64_t count = 0;
    int64_t bytes = 0;
  };
  std::vector<TopicSummary> topics;
  int64_t samples = 0, bytes = 0;
  int64_t first_arrival_ns = 0, last_arrival_ns = 0;
  std::map<std::string, std::string> meta;
  /// The writer did not close the file (killed, or the machine stopped): samples
  /// up to its last committed batch are there.
  bool interrupted = false;
  /// Empty if the file is sound; else what is wrong: SQLite's quick_check findings
  /// (damaged pages: counts may be wrong) and the number of samples whose CRC-32
  /// does not match their data.
  std::string damage;
  int64_t damaged_samples = 0;
  double duration_s() const { return samples ? double(last_arrival_ns - first_arrival_ns) * 1e-9 : 0.0; }
};

/// Reads a recording (read-only; works on a file whose writer was killed).
class RecordingReader {
 public:
  /// Throws RecordingError, naming the file and what is wrong, if the file is
  /// missing, empty, not SQLite, lacks a table or column of the format, has an
  /// unknown format, or a topics row without name or type.
  explicit RecordingReader(const std::string& path);
  ~RecordingReader();
  RecordingReader(const RecordingReader&) = delete;
  RecordingReader& operator=(const RecordingReader&) = delete;

  const std::vector<TopicInfo>& topics() const { return topics_; }
  /// Calls f on every sample in arrival order (ties by insertion), until f
  /// returns false. Samples of topics not in `topic_ids` (if given) are skipped;
  /// so are samples whose CRC-32 does not match (counted in damaged_samples()) or
  /// whose topic id is not in the topics table. Throws RecordingError (file named)
  /// if SQLite finds the file damaged on the way.
  void ForEach(const std::function<bool(const Sample&)>& f,
               const std::optional<std::vector<int64_t>>& topic_ids = std::nullopt) const;
  /// The latest arrival_ns among the samples of `topic_ids` (all topics if not
  /// given), by SQL MAX over the column (no sample data is read);
  /// nullopt if there are none. Throws RecordingError.
  std::optional<int64_t> LastArrivalNs(const std::optional<std::vector<int64_t>>& topic_ids = std::nullopt) const;
  /// Counts, sizes, meta, and a full check: quick_check and every sample's CRC.
  RecordingInfo Info() const;
  /// SQLite's quick_check of the file's structure: empty if sound, else its
  /// findings (at most 10 lines). Reads the whole file.
  std::string QuickCheck() const;
  /// Samples ForEach skipped for a CRC mismatch or an unknown topic, so far.
  int64_t damaged_samples() const { return damaged_; }

 private:
  std::string path_;
  sqlite3* db_ = nullptr;
  std::vector<TopicInfo> topics_;
  void Counts(RecordingInfo* info) const;  ///< Per-topic counts, time range, meta.
  bool has_crc_ = false;
  mutable int64_t damaged_ = 0;
};

/// True if `name` matches the glob `pattern` (`*`, `?`, `[...]`, as fnmatch).
bool TopicMatches(const std::string& pattern, const std::string& name);
/// A topic passes when it matches any include pattern (none given: all) and no
/// exclude pattern.
bool TopicSelected(const std::vector<std::string>& include, const std::vector<std::string>& exclude,
                   const std::string& name);

}  // namespace hullpipe::record
