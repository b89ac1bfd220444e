// Recordings of DDS traffic (docs/recording.md): serialized samples (CDR, untouched, with
// their encapsulation header) of every recorded topic, with source and arrival
// timestamps, in one of two storages (storage.h): SQLite files (.hprec, below) or
// MCAP files (.mcap: channels of message encoding `cdr` with `omgidl` schemas, the
// QoS in channel metadata 'qos', meta in metadata records "hullpipe"; see
// docs/recording.md "MCAP"). DDS-free: the recorder and the player tools put DDS
// on either side; tests use this library alone.
//
// SQLite file format (SQLite 3, WAL journal), 'hullpipe-recording-3':
//   meta(key TEXT PRIMARY KEY, value TEXT)   format, compression, created_ns,
//        closed_ns, set, part, lost:<topic>...
//   topics(id INTEGER PRIMARY KEY, name TEXT UNIQUE, type TEXT, keyed INTEGER,
//          reliable INTEGER, transient_local INTEGER, depth INTEGER,
//          type_description TEXT)                  the type's IDL text
//   samples(id INTEGER PRIMARY KEY, topic_id INTEGER, source_ns INTEGER,
//           arrival_ns INTEGER, data BLOB, crc INTEGER, codec INTEGER,
//           size INTEGER)                           in arrival order
// codec 0: data is the sample; 1: data is one zstd frame of it (a sample that
// zstd does not shrink is stored as it is). size is the sample's own size. crc is
// the CRC-32 (zlib) of topic_id, source_ns, arrival_ns (8 bytes each,
// little-endian) and the sample's own bytes (after decompression), so it checks
// the whole path. Formats 1 (no crc) and 2 (no codec, size, type_description)
// are still read.
// A split recording is a directory of such files (part_0000.hprec, ...), each a
// recording of its own with meta 'set' (one id for all) and 'part' (0, 1, ...);
// RecordingReader reads the directory as one recording.
// Samples are written in batched transactions: a writer killed (even by SIGKILL)
// loses at most its last, uncommitted batch, and the file still opens. A writer
// that closes sets meta 'closed_ns'; a file without it was interrupted.
// Readers open files read-only: reading never changes them. A file cut short or
// otherwise damaged is recovered by Repair (repair.h).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

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
  /// The IDL text that defines `type` in the recording build (dds/idl/*.idl), so
  /// another build or a tool that does not link hullpipe can read the samples;
  /// empty in recordings of formats 1 and 2.
  std::string type_description;
  /// MCAP only (SQLite recordings are CDR): the channel's message encoding, "cdr"
  /// for hullpipe's topics, "json" for the viewable channels `export --foxglove`
  /// writes; and the schema's encoding (empty: "omgidl" where type_description
  /// is given, else none).
  std::string message_encoding = "cdr";
  std::string schema_encoding;
  /// MCAP only: a ROS 2 channel's `offered_qos_profiles` (rosbag2's channel
  /// metadata: ros2/hullpipe/ros2/ros2_schemas.h), written instead of
  /// hullpipe's `qos` when given.
  std::string offered_qos_profiles;
};

/// How sample data is stored: per sample (SQLite) or per chunk (MCAP). lz4 (the
/// LZ4 frame format) is MCAP's only.
enum class Compression { kNone, kZstd, kLz4 };
/// "none" / "zstd" / "lz4"; ParseCompression throws std::invalid_argument naming --compression.
const char* CompressionName(Compression c);
Compression ParseCompression(const std::string& name);

/// Where a recording is kept (storage.h).
enum class Storage { kSqlite, kMcap };
/// "sqlite" / "mcap"; ParseStorage throws std::invalid_argument naming --storage.
const char* StorageName(Storage s);
Storage ParseStorage(const std::string& name);
/// The storage a path names by its extension: ".mcap" is MCAP, anything else SQLite.
Storage StorageForPath(const std::string& path);
/// A file's extension for a storage: ".hprec" / ".mcap".
const char* StorageExtension(Storage s);

/// Settings of RecordingWriter.
/// What only the MCAP storage reads (mcap_writer.cc): as rosbag2 keeps each
/// storage plugin's settings apart from the writer's.
struct McapWriterOptions {
  /// A chunk is closed (compressed, indexed, written) once its records reach
  /// this many bytes, and at every Commit(). 1 KiB .. 128 MiB (--chunk-size).
  int64_t chunk_bytes = int64_t(4) << 20;
  /// The header's profile: "" (hullpipe's channels) or "ros2" (a file of ROS 2
  /// channels only, as rosbag2 writes: `export --ros2`, docs/ros2.md).
  std::string profile;
};

/// A recording writer's settings: those of every storage, then each storage's own.
struct WriterOptions {
  /// SQLite: each sample's; MCAP: each chunk's (what the storage's
  /// StorageKind::compressions allow).
  Compression compression = Compression::kNone;
  int zstd_level = 1;  ///< 1 (fast) .. 19 (small); zstd's own scale.
  /// nullopt: by the path's extension (StorageForPath).
  std::optional<Storage> storage;
  McapWriterOptions mcap;
  /// Throws std::invalid_argument naming the flag (--zstd-level, --chunk-size,
  /// --compression lz4 on SQLite).
  void Check() const;
  void Check(Storage s) const;
};

/// The largest sample a reader decodes (a zstd frame claiming more is damage, not
/// an allocation): 1 GiB, far above hullpipe's largest message (a 1280x720 BGR
/// image is 2.8 MB).
constexpr int64_t kMaxSampleBytes = int64_t(1) << 30;

/// A zstd-stored sample (or a compressed MCAP chunk, zstd or lz4) of more than
/// kRatioFreeBytes (64 MiB) must be stored in
/// at least 1/kMaxZstdRatio of its size: a frame of a few KB claiming (and
/// made of run-length blocks that give) 1 GiB made `info` allocate 1.1 GB on
/// an 8-MB file. The writer stores a sample that would compress better than
/// that uncompressed, so every file it writes reads back.
constexpr int64_t kRatioFreeBytes = int64_t(64) << 20;
constexpr int64_t kMaxZstdRatio = 1024;
/// Whether `size` decoded bytes from `stored` stored bytes pass the rule above.
constexpr bool ZstdRatioPlausible(size_t stored, int64_t size) {
  return size <= kRatioFreeBytes || size / kMaxZstdRatio <= int64_t(stored);
}

/// One recorded sample.
struct Sample {
  int64_t topic_id = 0;
  int64_t source_ns = 0;      ///< The writer's source timestamp (CLOCK_REALTIME ns).
  int64_t arrival_ns = 0;     ///< When the recorder took it (CLOCK_REALTIME ns).
  std::vector<uint8_t> data;  ///< Serialized sample, CDR with its 4-byte header.
};

/// A sample as a file stores it (Repair copies rows so): its bytes encoded with
/// `codec` (0 none, 1 zstd), its own bytes `size` long with CRC-32 row checksum
/// `crc` (RowCrc). `data` is not owned.
struct EncodedSample {
  int64_t topic_id = 0;
  int64_t source_ns = 0;
  int64_t arrival_ns = 0;
  std::span<const uint8_t> data;
  int codec = 0;
  int64_t size = 0;
  uint32_t crc = 0;
};

/// The SQLite error policy: every failing call throws this, naming the call and
/// the file.
class RecordingError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class StorageWriter;
class StorageReader;

/// Appends to a new recording in the storage the options or the path's extension
/// name. Not thread-safe.
class RecordingWriter {
 public:
  /// Creates `path` (an existing file is an error: recordings are never
  /// overwritten). Throws RecordingError, or std::invalid_argument if options
  /// fail Check().
  explicit RecordingWriter(const std::string& path, const WriterOptions& options = {});
  ~RecordingWriter();  ///< Sets meta 'closed_ns' and commits the open batch.
  RecordingWriter(const RecordingWriter&) = delete;
  RecordingWriter& operator=(const RecordingWriter&) = delete;

  /// Adds a topic; returns its id (the same id if the name is already there).
  int64_t AddTopic(const TopicInfo& topic);
  /// Appends a sample to the open batch (a transaction or chunk opened on
  /// demand), compressed as the options say.
  void Append(const Sample& sample);
  /// Appends a sample as another file stored it (StorageWriter::AppendEncoded:
  /// SQLite keeps it as it is, MCAP decodes it). Throws RecordingError naming
  /// the file if it does not decode.
  void AppendEncoded(const EncodedSample& sample);
  /// Commits the open batch: after this returns, the samples survive a crash.
  void Commit();
  /// Sets a meta value (committed with the next batch).
  void SetMeta(const std::string& key, const std::string& value);
  int64_t samples_committed() const;
  int64_t samples_pending() const;
  /// Sample bytes as stored (after compression) and before it, so far.
  int64_t stored_bytes() const;
  int64_t raw_bytes() const;
  const std::string& path() const { return path_; }
  Storage storage() const { return storage_; }

 private:
  std::string path_;
  Storage storage_;
  std::unique_ptr<StorageWriter> impl_;
};

/// Summary of a recording (`hullpipe_record info`).
struct RecordingInfo {
  struct TopicSummary {
    TopicInfo topic;
    int64_t count = 0;
    int64_t bytes = 0;         ///< The samples' own bytes.
    int64_t stored_bytes = 0;  ///< As stored (compressed where it is).
    /// Samples the recorder's reader lost (DDS sample-lost / rejected), from meta
    /// 'lost:<topic>'; -1 where the recorder did not say (it did not stop cleanly).
    int64_t lost = -1;
  };
  std::vector<TopicSummary> topics;
  int64_t samples = 0, bytes = 0, stored_bytes = 0;
  int64_t first_arrival_ns = 0, last_arrival_ns = 0;
  std::map<std::string, std::string> meta;  ///< Later parts' values win.
  std::string format;       ///< meta 'format' of the (first) file ("mcap" for MCAP).
  std::string storage;      ///< "sqlite" or "mcap" (of the first file).
  std::string compression;  ///< "none", "zstd", "lz4", or "none, zstd" for a mixed set.
  /// The files read, in order (one, or a split recording's parts), and their
  /// sizes on disk (the database file and its WAL log, if any).
  std::vector<std::string> files;
  int64_t file_bytes = 0;
  /// The writer did not close the (last) file (killed, or the machine stopped):
  /// samples up to its last committed batch are there.
  bool interrupted = false;
  /// Empty if the recording is sound; else what is wrong: SQLite's quick_check
  /// findings (damaged pages: counts may be wrong), a missing part, and the number
  /// of samples whose CRC-32 does not match their data.
  std::string damage;
  int64_t damaged_samples = 0;
  double duration_s() const { return samples ? double(last_arrival_ns - first_arrival_ns) * 1e-9 : 0.0; }
};

/// Reads a recording in either storage: one file, or a directory holding the
/// parts of one split recording (.hprec or .mcap files), read as one (read-only;
/// works on a file whose writer was killed).
class RecordingReader {
 public:
  /// Throws RecordingError, naming the file and what is wrong, if the file is
  /// missing, empty, neither SQLite nor MCAP, lacks a table or column of the
  /// format, has an unknown format, or a topics row without name or type (MCAP:
  /// bad magic, a header or record that runs past the end, a channel whose
  /// schema does not exist); for a directory, also if it holds no recording file,
  /// files of more than one recording (meta 'set'), or two files of the same part.
  explicit RecordingReader(const std::string& path);
  ~RecordingReader();
  RecordingReader(const RecordingReader&) = delete;
  RecordingReader& operator=(const RecordingReader&) = delete;

  /// Every topic of every part, each name once (ids of a split recording's parts
  /// are mapped to these).
  const std::vector<TopicInfo>& topics() const { return topics_; }
  /// Calls f on every sample in arrival order (ties by insertion; parts one after
  /// the other), decompressed, until f returns false. Samples of topics not in
  /// `topic_ids` (if given) are skipped before their data is read or decoded; so
  /// are samples whose CRC-32 does not match, whose zstd frame does not decode to
  /// its recorded size, or whose topic id is not in the topics table (counted in
  /// damaged_samples()). Throws RecordingError (file named) if SQLite finds a file
  /// damaged on the way.
  void ForEach(const std::function<bool(const Sample&)>& f,
               const std::optional<std::vector<int64_t>>& topic_ids = std::nullopt) const;
  /// The earliest / latest arrival_ns among the samples of `topic_ids` (all topics
  /// if not given), by SQL MIN/MAX over the column (no sample data is read);
  /// nullopt if there are none. Throws RecordingError.
  std::optional<int64_t> FirstArrivalNs(const std::optional<std::vector<int64_t>>& topic_ids = std::nullopt) const;
  std::optional<int64_t> LastArrivalNs(const std::optional<std::vector<int64_t>>& topic_ids = std::nullopt) const;
  /// Counts, sizes, meta, and a full check: quick_check and every sample's CRC.
  RecordingInfo Info() const;
  /// Every file's structural check (SQLite's quick_check; MCAP: records, chunk
  /// CRCs and sizes, the summary): empty if sound, else the findings (at most 10
  /// a file). Reads the whole recording.
  std::string QuickCheck() const;
  /// Samples ForEach skipped for a CRC mismatch, a bad frame or an unknown topic, so far.
  int64_t damaged_samples() const { return damaged_; }
  /// A split recording's parts found missing at open ("part 2 missing, part 5
  /// missing"); empty when none is. Replay and export read the rest and exit 3.
  const std::string& missing_parts() const { return missing_parts_; }
  /// The files read, in order.
  std::vector<std::string> files() const;

 private:
  struct Part;
  std::string path_;
  std::vector<std::unique_ptr<Part>> parts_;
  std::vector<TopicInfo> topics_;
  std::string missing_parts_;  ///< "part 2 missing", found at open
  void Counts(RecordingInfo* info) const;  ///< Per-topic counts, time range, meta.
  std::optional<int64_t> ArrivalBound(const char* fn, const std::optional<std::vector<int64_t>>& topic_ids) const;
  mutable int64_t damaged_ = 0;
};

/// True if the file's first bytes are MCAP's magic (it may still be damaged).
bool IsMcapFile(const std::string& path);

/// Decodes one stored sample: codec 0 copies, 1 decompresses a zstd frame that
/// must decode to exactly `size` bytes (<= kMaxSampleBytes, ZstdRatioPlausible).
/// The output grows with what the frame really gives, so a frame that stops
/// short costs what it gave, not what it claimed. False if it does not decode.
bool DecodeSampleData(const uint8_t* data, size_t n, int codec, int64_t size, std::vector<uint8_t>* out);
/// The row checksum of the format (header comment).
uint32_t RowCrc(int64_t topic_id, int64_t source_ns, int64_t arrival_ns, const uint8_t* data, size_t size);

/// True if `name` matches the glob `pattern` (`*`, `?`, `[...]`, as fnmatch).
bool TopicMatches(const std::string& pattern, const std::string& name);
/// A topic passes when it matches any include pattern (none given: all) and no
/// exclude pattern.
bool TopicSelected(const std::vector<std::string>& include, const std::vector<std::string>& exclude,
                   const std::string& name);

}  // namespace hullpipe::record
