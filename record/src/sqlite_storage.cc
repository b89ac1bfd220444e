// The SQLite storage: the file format in recording.h ('hullpipe-recording-3',
// formats 1 and 2 still read).
#include <sqlite3.h>
#include <zstd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <set>

#include "hullpipe/record/storage.h"

namespace hullpipe::record {
namespace {

void CheckSql(int rc, sqlite3* db, const char* call, const std::string& path) {
  if (rc == SQLITE_OK || rc == SQLITE_DONE || rc == SQLITE_ROW) return;
  throw RecordingError(path + ": " + call + ": " + (db ? sqlite3_errmsg(db) : sqlite3_errstr(rc)));
}

// sqlite3_open_v2 allocates a handle even when it fails: closed here before
// the error is thrown (a constructor that throws runs no destructor).
sqlite3* Open(const std::string& path, int flags) {
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &db, flags, nullptr);
  if (rc != SQLITE_OK) {
    const std::string msg = db ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
    sqlite3_close(db);
    throw RecordingError(path + ": sqlite3_open_v2: " + msg);
  }
  return db;
}

void Exec(sqlite3* db, const char* sql, const std::string& path) {
  char* err = nullptr;
  const int rc = sqlite3_exec(db, sql, nullptr, nullptr, &err);
  if (rc != SQLITE_OK) {
    const std::string msg = err ? err : sqlite3_errstr(rc);
    sqlite3_free(err);
    throw RecordingError(path + ": " + sql + ": " + msg);
  }
}

// Text of column i, or nullptr for NULL.
const char* Text(sqlite3_stmt* st, int i) { return reinterpret_cast<const char*>(sqlite3_column_text(st, i)); }

constexpr const char* kFormat = "hullpipe-recording-3";
constexpr const char* kFormat2 = "hullpipe-recording-2";
constexpr const char* kFormat1 = "hullpipe-recording-1";

// A prepared statement, finalized on scope exit.
struct Stmt {
  sqlite3_stmt* s = nullptr;
  Stmt(sqlite3* db, const char* sql, const std::string& path) {
    CheckSql(sqlite3_prepare_v2(db, sql, -1, &s, nullptr), db, "sqlite3_prepare_v2", path);
  }
  ~Stmt() { sqlite3_finalize(s); }
};

std::string IdList(const std::set<int64_t>& ids) {
  std::string out;
  for (int64_t id : ids) out += (out.empty() ? "" : ",") + std::to_string(id);
  return out;
}

class SqliteWriter final : public StorageWriter {
 public:
  SqliteWriter(const std::string& path, const WriterOptions& options);
  ~SqliteWriter() override;
  const std::string& path() const override { return path_; }
  int64_t AddTopic(const TopicInfo& topic) override;
  void Append(const Sample& sample) override;
  /// Stored as it is: Repair's rows keep their codec and checksum.
  void AppendEncoded(const EncodedSample& sample) override;
  void Commit() override;
  void SetMeta(const std::string& key, const std::string& value) override;
  int64_t samples_committed() const override { return committed_; }
  int64_t samples_pending() const override { return pending_; }
  int64_t stored_bytes() const override { return stored_bytes_; }
  int64_t raw_bytes() const override { return raw_bytes_; }

 private:
  void Begin();
  WriterOptions options_;
  ZSTD_CCtx* zstd_ = nullptr;  // reused
  std::vector<uint8_t> scratch_;
  int64_t stored_bytes_ = 0, raw_bytes_ = 0;
  std::string path_;
  sqlite3* db_ = nullptr;
  sqlite3_stmt* insert_ = nullptr;
  bool in_txn_ = false;
  int64_t committed_ = 0, pending_ = 0;
};

SqliteWriter::SqliteWriter(const std::string& path, const WriterOptions& options) : options_(options), path_(path) {
  options_.Check(Storage::kSqlite);
  if (std::filesystem::exists(path)) throw RecordingError(path + ": exists; recordings are never overwritten");
  db_ = Open(path, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  try {
    // WAL: a commit is durable once its frames are in the log; a killed writer
    // leaves the log, which the next open replays up to the last commit.
    // 16 KiB pages: a 1 MiB sample spans 64 overflow pages instead of 256 (1.3x the
    // write rate of 4 KiB pages; 64 KiB gains little more and wastes 9% on small
    // samples: docs/benchmarks.md, "Recording throughput").
    Exec(db_, "PRAGMA page_size=16384", path_);
    Exec(db_, "PRAGMA journal_mode=WAL", path_);
    Exec(db_, "PRAGMA synchronous=NORMAL", path_);
    Exec(db_,
         "CREATE TABLE meta(key TEXT PRIMARY KEY, value TEXT);"
         "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT UNIQUE NOT NULL, type TEXT NOT NULL,"
         " keyed INTEGER, reliable INTEGER, transient_local INTEGER, depth INTEGER, type_description TEXT);"
         "CREATE TABLE samples(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, source_ns INTEGER,"
         " arrival_ns INTEGER, data BLOB, crc INTEGER, codec INTEGER, size INTEGER);"
         "INSERT INTO meta VALUES('format', 'hullpipe-recording-3');",
         path_);
    SetMeta("compression", CompressionName(options_.compression));
    CheckSql(
        sqlite3_prepare_v2(
            db_, "INSERT INTO samples(topic_id, source_ns, arrival_ns, data, crc, codec, size) VALUES(?,?,?,?,?,?,?)",
            -1, &insert_, nullptr),
        db_, "sqlite3_prepare_v2", path_);
    if (options_.compression == Compression::kZstd) {
      zstd_ = ZSTD_createCCtx();
      if (!zstd_) throw RecordingError(path_ + ": ZSTD_createCCtx failed");
      ZSTD_CCtx_setParameter(zstd_, ZSTD_c_compressionLevel, options_.zstd_level);
    }
  } catch (...) {
    sqlite3_finalize(insert_);
    sqlite3_close(db_);
    throw;
  }
}

SqliteWriter::~SqliteWriter() {
  try {
    SetMeta("closed_ns", std::to_string(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                            std::chrono::system_clock::now().time_since_epoch())
                                            .count()));
    Commit();
  } catch (...) {
  }
  ZSTD_freeCCtx(zstd_);
  sqlite3_finalize(insert_);
  sqlite3_close(db_);
}

void SqliteWriter::Begin() {
  if (!in_txn_) {
    Exec(db_, "BEGIN", path_);
    in_txn_ = true;
  }
}

int64_t SqliteWriter::AddTopic(const TopicInfo& t) {
  {
    Stmt find(db_, "SELECT id FROM topics WHERE name = ?", path_);
    sqlite3_bind_text(find.s, 1, t.name.c_str(), -1, SQLITE_TRANSIENT);
    if (sqlite3_step(find.s) == SQLITE_ROW) return sqlite3_column_int64(find.s, 0);
  }
  Begin();
  Stmt ins(db_,
           "INSERT INTO topics(name, type, keyed, reliable, transient_local, depth, type_description)"
           " VALUES(?,?,?,?,?,?,?)",
           path_);
  sqlite3_bind_text(ins.s, 1, t.name.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_text(ins.s, 2, t.type.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_int(ins.s, 3, t.keyed);
  sqlite3_bind_int(ins.s, 4, t.reliable);
  sqlite3_bind_int(ins.s, 5, t.transient_local);
  sqlite3_bind_int(ins.s, 6, t.depth);
  sqlite3_bind_text(ins.s, 7, t.type_description.c_str(), -1, SQLITE_TRANSIENT);
  CheckSql(sqlite3_step(ins.s), db_, "INSERT INTO topics", path_);
  return sqlite3_last_insert_rowid(db_);
}

void SqliteWriter::Append(const Sample& s) {
  const uint32_t crc = RowCrc(s.topic_id, s.source_ns, s.arrival_ns, s.data.data(), s.data.size());
  if (zstd_) {
    scratch_.resize(ZSTD_compressBound(s.data.size()));
    const size_t n = ZSTD_compress2(zstd_, scratch_.data(), scratch_.size(), s.data.data(), s.data.size());
    if (ZSTD_isError(n)) throw RecordingError(path_ + ": ZSTD_compress2: " + ZSTD_getErrorName(n));
    if (n < s.data.size() && ZstdRatioPlausible(n, int64_t(s.data.size()))) {  // else stored as it is
      scratch_.resize(n);
      AppendEncoded({.topic_id = s.topic_id, .source_ns = s.source_ns, .arrival_ns = s.arrival_ns,
                     .data = scratch_, .codec = 1, .size = int64_t(s.data.size()), .crc = crc});
      return;
    }
  }
  AppendEncoded({.topic_id = s.topic_id, .source_ns = s.source_ns, .arrival_ns = s.arrival_ns, .data = s.data,
                 .codec = 0, .size = int64_t(s.data.size()), .crc = crc});
}

void SqliteWriter::AppendEncoded(const EncodedSample& e) {
  Begin();
  sqlite3_reset(insert_);
  sqlite3_bind_int64(insert_, 1, e.topic_id);
  sqlite3_bind_int64(insert_, 2, e.source_ns);
  sqlite3_bind_int64(insert_, 3, e.arrival_ns);
  sqlite3_bind_blob64(insert_, 4, e.data.data(), e.data.size(), SQLITE_STATIC);
  sqlite3_bind_int64(insert_, 5, e.crc);
  sqlite3_bind_int(insert_, 6, e.codec);
  sqlite3_bind_int64(insert_, 7, e.size);
  CheckSql(sqlite3_step(insert_), db_, "INSERT INTO samples", path_);
  ++pending_;
  stored_bytes_ += int64_t(e.data.size());
  raw_bytes_ += e.size;
}

void SqliteWriter::SetMeta(const std::string& key, const std::string& value) {
  Begin();
  Stmt st(db_, "INSERT OR REPLACE INTO meta(key, value) VALUES(?, ?)", path_);
  sqlite3_bind_text(st.s, 1, key.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_text(st.s, 2, value.c_str(), -1, SQLITE_TRANSIENT);
  CheckSql(sqlite3_step(st.s), db_, "INSERT INTO meta", path_);
}

void SqliteWriter::Commit() {
  if (!in_txn_) return;
  Exec(db_, "COMMIT", path_);
  in_txn_ = false;
  committed_ += pending_;
  pending_ = 0;
}

class SqliteReader final : public StorageReader {
 public:
  explicit SqliteReader(const std::string& path);
  ~SqliteReader() override { sqlite3_close(db_); }
  const std::string& path() const override { return path_; }
  Storage storage() const override { return Storage::kSqlite; }
  const std::vector<TopicInfo>& topics() const override { return topics_; }
  const std::map<std::string, std::string>& meta() const override { return meta_; }
  std::string format() const override { return meta_.count("format") ? meta_.at("format") : ""; }
  // Files of format 1 were closed by the recorder tool, which set stopped_ns.
  bool interrupted() const override {
    return (!meta_.count("closed_ns") && !meta_.count("stopped_ns")) || meta_.count("interrupted");
  }
  bool ForEach(const std::optional<std::set<int64_t>>& ids, const std::function<bool(const Sample&)>& f,
               int64_t* damaged) const override;
  std::optional<int64_t> ArrivalBound(bool max, const std::optional<std::set<int64_t>>& ids) const override;
  std::string QuickCheck() const override;
  std::map<int64_t, TopicCount> Counts() const override;
  int64_t FileBytes() const override {
    std::error_code ec;
    int64_t n = 0;
    for (const std::string& p : {path_, path_ + "-wal"}) {
      const auto size = std::filesystem::file_size(p, ec);
      if (!ec) n += int64_t(size);
    }
    return n;
  }

 private:
  std::string path_;
  sqlite3* db_ = nullptr;
  int format_ = 3;  // 1, 2 or 3
  std::vector<TopicInfo> topics_;
  std::set<int64_t> topic_ids_;
  std::map<std::string, std::string> meta_;
};

SqliteReader::SqliteReader(const std::string& path) : path_(path) {
  // Read-only: reading never changes the file. A killed writer's WAL is still
  // read (SQLite reads the log of a read-only connection; nothing is checkpointed).
  db_ = Open(path, SQLITE_OPEN_READONLY);
  try {
    auto not_ours = [&](const std::string& why) {
      return RecordingError(path + ": not a hullpipe recording (" + why + ")");
    };
    std::set<std::string> tables;
    {
      sqlite3_stmt* st = nullptr;
      if (sqlite3_prepare_v2(db_, "SELECT name FROM sqlite_master WHERE type = 'table'", -1, &st, nullptr) !=
          SQLITE_OK) {
        const std::string msg = sqlite3_errmsg(db_);
        sqlite3_finalize(st);
        throw not_ours(msg);
      }
      int rc;
      while ((rc = sqlite3_step(st)) == SQLITE_ROW)
        if (const char* n = Text(st, 0)) tables.insert(n);
      sqlite3_finalize(st);
      if (rc != SQLITE_DONE) throw not_ours(sqlite3_errstr(rc));
    }
    for (const char* t : {"meta", "topics", "samples"})
      if (!tables.count(t)) throw not_ours(std::string("no table '") + t + "'");
    {
      Stmt meta(db_, "SELECT key, value FROM meta", path);
      int rc;
      while ((rc = sqlite3_step(meta.s)) == SQLITE_ROW) {
        const char* k = Text(meta.s, 0);
        const char* v = Text(meta.s, 1);
        if (k && !v && std::string(k) == "format") throw not_ours("meta 'format' is NULL");
        if (k) meta_[k] = v ? v : "";
      }
      CheckSql(rc, db_, "SELECT FROM meta", path);
    }
    if (!meta_.count("format")) throw not_ours("no meta 'format'");
    const std::string f = meta_.at("format");
    if (f == kFormat) format_ = 3;
    else if (f == kFormat2) format_ = 2;
    else if (f == kFormat1) format_ = 1;
    else throw not_ours("format '" + f + "'; this build reads " + kFormat + ", " + kFormat2 + " and " + kFormat1);
    {
      // The columns the reader selects, so a table of the wrong shape is named
      // here rather than failing in the middle of a replay.
      const char* sql = format_ == 3
                            ? "SELECT topic_id, source_ns, arrival_ns, data, crc, codec, size FROM samples LIMIT 0"
                        : format_ == 2 ? "SELECT topic_id, source_ns, arrival_ns, data, crc FROM samples LIMIT 0"
                                       : "SELECT topic_id, source_ns, arrival_ns, data FROM samples LIMIT 0";
      sqlite3_stmt* st = nullptr;
      const int rc = sqlite3_prepare_v2(db_, sql, -1, &st, nullptr);
      const std::string msg = sqlite3_errmsg(db_);
      sqlite3_finalize(st);
      if (rc != SQLITE_OK) throw not_ours("table 'samples': " + msg);
    }
    Stmt st(
        db_,
        format_ == 3
            ? "SELECT id, name, type, keyed, reliable, transient_local, depth, type_description FROM topics ORDER BY id"
            : "SELECT id, name, type, keyed, reliable, transient_local, depth, NULL FROM topics ORDER BY id",
        path);
    int rc;
    while ((rc = sqlite3_step(st.s)) == SQLITE_ROW) {
      TopicInfo t;
      t.id = sqlite3_column_int64(st.s, 0);
      const char* name = Text(st.s, 1);
      const char* type = Text(st.s, 2);
      if (!name || !type)
        throw RecordingError(path + ": topics row " + std::to_string(t.id) + " has no " + (name ? "type" : "name"));
      t.name = name;
      t.type = type;
      t.keyed = sqlite3_column_int(st.s, 3);
      t.reliable = sqlite3_column_int(st.s, 4);
      t.transient_local = sqlite3_column_int(st.s, 5);
      t.depth = sqlite3_column_int(st.s, 6);
      if (const char* d = Text(st.s, 7)) t.type_description = d;
      topics_.push_back(t);
      topic_ids_.insert(t.id);
    }
    CheckSql(rc, db_, "SELECT FROM topics", path);
  } catch (...) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw;
  }
}

bool SqliteReader::ForEach(const std::optional<std::set<int64_t>>& ids, const std::function<bool(const Sample&)>& f,
                           int64_t* damaged) const {
  // The topic filter runs in SQL, so a replay of one topic reads no other's data.
  std::string where;
  if (ids) {
    if (ids->empty()) return true;
    where = " WHERE topic_id IN (" + IdList(*ids) + ")";
  }
  const std::string cols = format_ == 3   ? "topic_id, source_ns, arrival_ns, data, crc, codec, size"
                           : format_ == 2 ? "topic_id, source_ns, arrival_ns, data, crc, 0, -1"
                                          : "topic_id, source_ns, arrival_ns, data, NULL, 0, -1";
  const std::string sql = "SELECT " + cols + " FROM samples" + where + " ORDER BY arrival_ns, id";
  Stmt st(db_, sql.c_str(), path_);
  Sample s;
  int rc;
  while ((rc = sqlite3_step(st.s)) == SQLITE_ROW) {
    s.topic_id = sqlite3_column_int64(st.s, 0);
    s.source_ns = sqlite3_column_int64(st.s, 1);
    s.arrival_ns = sqlite3_column_int64(st.s, 2);
    const auto* data = static_cast<const uint8_t*>(sqlite3_column_blob(st.s, 3));
    const int n = sqlite3_column_bytes(st.s, 3);
    const int codec = sqlite3_column_int(st.s, 5);
    const int64_t size = sqlite3_column_int64(st.s, 6);
    bool ok = topic_ids_.count(s.topic_id) > 0;
    if (ok && codec == 0) {
      if (data) s.data.assign(data, data + n);
      else s.data.clear();
      ok = size < 0 || size == n;
    } else if (ok) {
      ok = data && DecodeSampleData(data, size_t(n), codec, size, &s.data);
    }
    if (ok && format_ >= 2)
      ok = sqlite3_column_type(st.s, 4) == SQLITE_INTEGER &&
           uint32_t(sqlite3_column_int64(st.s, 4)) ==
               RowCrc(s.topic_id, s.source_ns, s.arrival_ns, s.data.data(), s.data.size());
    if (!ok) {
      ++*damaged;
      continue;
    }
    if (!f(s)) return false;
  }
  CheckSql(rc, db_, "SELECT FROM samples", path_);
  return true;
}

std::optional<int64_t> SqliteReader::ArrivalBound(bool max, const std::optional<std::set<int64_t>>& ids) const {
  std::string sql = std::string("SELECT ") + (max ? "MAX" : "MIN") + "(arrival_ns) FROM samples";
  if (ids) {
    if (ids->empty()) return std::nullopt;
    sql += " WHERE topic_id IN (" + IdList(*ids) + ")";
  }
  Stmt st(db_, sql.c_str(), path_);
  CheckSql(sqlite3_step(st.s), db_, max ? "MAX" : "MIN", path_);
  if (sqlite3_column_type(st.s, 0) == SQLITE_NULL) return std::nullopt;
  return sqlite3_column_int64(st.s, 0);
}

std::string SqliteReader::QuickCheck() const {
  Stmt st(db_, "PRAGMA quick_check(10)", path_);
  std::string mine;
  int rc;
  while ((rc = sqlite3_step(st.s)) == SQLITE_ROW) {
    const char* line = Text(st.s, 0);
    if (line && std::string(line) == "ok") continue;
    mine += (mine.empty() ? "" : "; ") + std::string(line ? line : "?");
  }
  if (rc != SQLITE_DONE) mine += (mine.empty() ? "" : "; ") + std::string(sqlite3_errmsg(db_));
  return mine;
}

std::map<int64_t, StorageReader::TopicCount> SqliteReader::Counts() const {
  const char* sql =
      format_ == 3 ? "SELECT topic_id, COUNT(*), COALESCE(SUM(CASE WHEN size >= 0 THEN size ELSE LENGTH(data) END), 0),"
                     " COALESCE(SUM(LENGTH(data)), 0) FROM samples GROUP BY topic_id"
                   : "SELECT topic_id, COUNT(*), COALESCE(SUM(LENGTH(data)), 0), COALESCE(SUM(LENGTH(data)), 0)"
                     " FROM samples GROUP BY topic_id";
  Stmt st(db_, sql, path_);
  std::map<int64_t, TopicCount> out;
  int rc;
  while ((rc = sqlite3_step(st.s)) == SQLITE_ROW) {
    auto& c = out[sqlite3_column_int64(st.s, 0)];
    c.count += sqlite3_column_int64(st.s, 1);
    c.bytes += sqlite3_column_int64(st.s, 2);
    c.stored_bytes += sqlite3_column_int64(st.s, 3);
  }
  CheckSql(rc, db_, "SELECT COUNT", path_);
  return out;
}

}  // namespace

std::unique_ptr<StorageWriter> OpenSqliteWriter(const std::string& path, const WriterOptions& options) {
  return std::make_unique<SqliteWriter>(path, options);
}

std::unique_ptr<StorageReader> OpenSqliteReader(const std::string& path) {
  return std::make_unique<SqliteReader>(path);
}

}  // namespace hullpipe::record
