// The storages a recording is kept in, behind one writer and one reader
// interface (as rosbag2's storage plugins): SQLite (sqlite_storage.cc, the
// format in recording.h) and MCAP (mcap_writer.cc and mcap_reader.cc,
// docs/recording.md "MCAP"; https://mcap.dev/spec), each registered once in
// Storages() with its name, extension, compressions, probe and openers.
// RecordingWriter and RecordingReader (recording.h) pick the storage from that
// table and hold one of these; the tools never see which.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "hullpipe/record/recording.h"
#include "hullpipe/record/repair.h"

namespace hullpipe::record {

/// One storage's writer of one file. Not thread-safe. The contract is
/// RecordingWriter's (recording.h): topics get ids 1, 2, ... in the order added;
/// a sample appended is durable (survives the writer's death) once Commit()
/// returns; the destructor marks the file closed (meta 'closed_ns').
class StorageWriter {
 public:
  virtual ~StorageWriter() = default;
  virtual const std::string& path() const = 0;  ///< The file written.
  virtual int64_t AddTopic(const TopicInfo& topic) = 0;
  virtual void Append(const Sample& sample) = 0;
  /// A sample as another file stored it (Repair copies rows so). The default
  /// decodes it (DecodeSampleData) and appends it; a storage that keeps samples
  /// as given (SQLite) stores it as it is. Throws RecordingError naming the
  /// file if it does not decode.
  virtual void AppendEncoded(const EncodedSample& sample);
  virtual void Commit() = 0;
  virtual void SetMeta(const std::string& key, const std::string& value) = 0;
  virtual int64_t samples_committed() const = 0;
  virtual int64_t samples_pending() const = 0;
  virtual int64_t stored_bytes() const = 0;  ///< Sample bytes as stored (after compression)
  virtual int64_t raw_bytes() const = 0;     ///< Sample bytes before compression
};

/// One storage's reader of one file (read-only: reading never changes it). Topic
/// ids are the file's own.
class StorageReader {
 public:
  virtual ~StorageReader() = default;
  virtual const std::string& path() const = 0;
  virtual Storage storage() const = 0;
  virtual const std::vector<TopicInfo>& topics() const = 0;
  /// The file's meta values (SQLite: table meta; MCAP: metadata records named
  /// "hullpipe", later records' values winning).
  virtual const std::map<std::string, std::string>& meta() const = 0;
  /// The format name `info` prints ("hullpipe-recording-3", "mcap").
  virtual std::string format() const = 0;
  /// True where the writer did not close the file (no closed_ns; for MCAP also a
  /// file without its footer).
  virtual bool interrupted() const = 0;
  /// Calls f on every sample of the topics in `ids` (all if nullopt) in arrival
  /// order (ties in write order), its data decoded, its topic id the file's.
  /// Samples that do not check (CRC, frame, unknown topic) are skipped and
  /// counted in *damaged. Returns false if f returned false. Throws
  /// RecordingError (file named) on structural damage met on the way.
  virtual bool ForEach(const std::optional<std::set<int64_t>>& ids, const std::function<bool(const Sample&)>& f,
                       int64_t* damaged) const = 0;
  /// The earliest (max false) or latest (max true) arrival among the samples of
  /// `ids` (all if nullopt), from the index where the storage has one.
  virtual std::optional<int64_t> ArrivalBound(bool max, const std::optional<std::set<int64_t>>& ids) const = 0;
  /// Structural check: empty if sound, else findings (a few lines at most).
  virtual std::string QuickCheck() const = 0;
  struct TopicCount {
    int64_t count = 0, bytes = 0, stored_bytes = 0;
  };
  /// Per file topic id: samples, their own bytes and their bytes as stored (for
  /// MCAP, each compressed chunk's size shared out by its messages' sizes).
  virtual std::map<int64_t, TopicCount> Counts() const = 0;
  /// The samples a ForEach over every topic would count as damaged, where the
  /// storage knows it without reading every sample again (MCAP: from its one
  /// survey of each chunk, whose CRC covers its samples); std::nullopt where
  /// only that ForEach can tell (SQLite: a CRC per row).
  virtual std::optional<int64_t> DamagedSamples() const { return std::nullopt; }
  /// Bytes on disk (SQLite: the file and its WAL log).
  virtual int64_t FileBytes() const = 0;
};

/// One storage as registered (rosbag2's storage plugins): --storage's names,
/// the extensions, what each may compress with and how a file is recognised and
/// opened come from this table alone.
struct StorageKind {
  Storage id;
  const char* name;       ///< --storage: "sqlite", "mcap"
  const char* extension;  ///< ".hprec", ".mcap"
  std::vector<Compression> compressions;  ///< What --compression may be.
  /// True if it keeps CDR samples only (TopicInfo::message_encoding "cdr").
  bool cdr_only = false;
  /// True if the file's first bytes are this storage's; nullptr: the storage
  /// of a file no other claims (its reader names what is wrong with it).
  bool (*probe)(const std::string& path);
  /// Writers: `path` must not exist (never overwritten). Throw RecordingError.
  std::unique_ptr<StorageWriter> (*open_writer)(const std::string& path, const WriterOptions& options);
  /// Readers. Throw RecordingError naming the file and what is wrong.
  std::unique_ptr<StorageReader> (*open_reader)(const std::string& path);
  /// Repair of a damaged file into `out` (repair.h); nullptr: what the reader
  /// reads is copied (RepairByReading).
  RepairReport (*repair)(const std::string& in, const std::string& out);
};

/// Every storage, SQLite first: the storage of a path with no other's extension.
const std::vector<StorageKind>& Storages();
/// The registered storage `id`.
const StorageKind& StorageKindOf(Storage id);
/// The registered storage whose probe claims the file at `path`, else the one
/// registered without a probe (SQLite, whose reader says what the file is not).
const StorageKind& StorageKindOfFile(const std::string& path);

/// Repairs (repair.h's Repair, its checks of `in` and `out` done): every sample
/// the storage's reader reads, copied in arrival order into a new recording.
RepairReport RepairByReading(const std::string& in, const std::string& out);
/// SQLite's page-level repair (docs/recording.md, "Repair"): rows read from the
/// file's pages and its WAL log, each checked against its CRC.
RepairReport RepairSqlitePages(const std::string& in, const std::string& out);

/// Writers: `path` must not exist (never overwritten). Throw RecordingError.
std::unique_ptr<StorageWriter> OpenSqliteWriter(const std::string& path, const WriterOptions& options);
std::unique_ptr<StorageWriter> OpenMcapWriter(const std::string& path, const WriterOptions& options);
/// Readers; OpenStorageReader picks by the file's first bytes (each registered
/// storage's probe; a file none claims is SQLite's to refuse). Throw
/// RecordingError naming the file and what is wrong.
std::unique_ptr<StorageReader> OpenSqliteReader(const std::string& path);
std::unique_ptr<StorageReader> OpenMcapReader(const std::string& path);
std::unique_ptr<StorageReader> OpenStorageReader(const std::string& path);

}  // namespace hullpipe::record
