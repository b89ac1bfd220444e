#include "hullpipe/record/recording.h"

#include <fnmatch.h>
#include <sqlite3.h>
#include <zlib.h>

#include <chrono>
#include <filesystem>
#include <set>

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

// CRC-32 (zlib) of a sample's row: topic id, source and arrival times (8 bytes
// each, little-endian) and the data, so a flip in any of them is found.
uint32_t RowCrc(int64_t topic_id, int64_t source_ns, int64_t arrival_ns, const uint8_t* data, size_t size) {
  uLong c = crc32(0L, Z_NULL, 0);
  for (int64_t v : {topic_id, source_ns, arrival_ns}) {
    uint8_t le[8];
    for (int i = 0; i < 8; ++i) le[i] = uint8_t(uint64_t(v) >> (8 * i));
    c = crc32(c, le, 8);
  }
  size_t off = 0;
  while (off < size) {  // zlib takes uInt lengths
    const size_t n = std::min<size_t>(size - off, 1u << 30);
    c = crc32(c, data + off, uInt(n));
    off += n;
  }
  return uint32_t(c);
}

// Text of column i, or nullptr for NULL.
const char* Text(sqlite3_stmt* st, int i) { return reinterpret_cast<const char*>(sqlite3_column_text(st, i)); }

constexpr const char* kFormat = "hullpipe-recording-2";
constexpr const char* kFormatNoCrc = "hullpipe-recording-1";

// A prepared statement, finalized on scope exit.
struct Stmt {
  sqlite3_stmt* s = nullptr;
  Stmt(sqlite3* db, const char* sql, const std::string& path) {
    CheckSql(sqlite3_prepare_v2(db, sql, -1, &s, nullptr), db, "sqlite3_prepare_v2", path);
  }
  ~Stmt() { sqlite3_finalize(s); }
};

}  // namespace

RecordingWriter::RecordingWriter(const std::string& path) : path_(path) {
  if (std::filesystem::exists(path)) throw RecordingError(path + ": exists; recordings are never overwritten");
  db_ = Open(path, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  try {
    // WAL: a commit is durable once its frames are in the log; a killed writer
    // leaves the log, which the next open replays up to the last commit.
    Exec(db_, "PRAGMA journal_mode=WAL", path_);
    Exec(db_, "PRAGMA synchronous=NORMAL", path_);
    Exec(db_,
         "CREATE TABLE meta(key TEXT PRIMARY KEY, value TEXT);"
         "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT UNIQUE NOT NULL, type TEXT NOT NULL,"
         " keyed INTEGER, reliable INTEGER, transient_local INTEGER, depth INTEGER);"
         "CREATE TABLE samples(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, source_ns INTEGER,"
         " arrival_ns INTEGER, data BLOB, crc INTEGER);"
         "INSERT INTO meta VALUES('format', 'hullpipe-recording-2');",
         path_);
    CheckSql(sqlite3_prepare_v2(db_, "INSERT INTO samples(topic_id, source_ns, arrival_ns, data, crc) VALUES(?,?,?,?,?)",
                                -1, &insert_, nullptr),
             db_, "sqlite3_prepare_v2", path_);
  } catch (...) {
    sqlite3_close(db_);
    throw;
  }
}

RecordingWriter::~RecordingWriter() {
  try {
    SetMeta("closed_ns", std::to_string(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                            std::chrono::system_clock::now().time_since_epoch())
                                            .count()));
    Commit();
  } catch (...) {
  }
  sqlite3_finalize(insert_);
  sqlite3_close(db_);
}

void RecordingWriter::Begin() {
  if (!in_txn_) {
    Exec(db_, "BEGIN", path_);
    in_txn_ = true;
  }
}

int64_t RecordingWriter::AddTopic(const TopicInfo& t) {
  {
    Stmt find(db_, "SELECT id FROM topics WHERE name = ?", path_);
    sqlite3_bind_text(find.s, 1, t.name.c_str(), -1, SQLITE_TRANSIENT);
    if (sqlite3_step(find.s) == SQLITE_ROW) return sqlite3_column_int64(find.s, 0);
  }
  Begin();
  Stmt ins(db_, "INSERT INTO topics(name, type, keyed, reliable, transient_local, depth) VALUES(?,?,?,?,?,?)", path_);
  sqlite3_bind_text(ins.s, 1, t.name.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_text(ins.s, 2, t.type.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_int(ins.s, 3, t.keyed);
  sqlite3_bind_int(ins.s, 4, t.reliable);
  sqlite3_bind_int(ins.s, 5, t.transient_local);
  sqlite3_bind_int(ins.s, 6, t.depth);
  CheckSql(sqlite3_step(ins.s), db_, "INSERT INTO topics", path_);
  return sqlite3_last_insert_rowid(db_);
}

void RecordingWriter::Append(const Sample& s) {
  Begin();
  sqlite3_reset(insert_);
  sqlite3_bind_int64(insert_, 1, s.topic_id);
  sqlite3_bind_int64(insert_, 2, s.source_ns);
  sqlite3_bind_int64(insert_, 3, s.arrival_ns);
  sqlite3_bind_blob64(insert_, 4, s.data.data(), s.data.size(), SQLITE_STATIC);
  sqlite3_bind_int64(insert_, 5, RowCrc(s.topic_id, s.source_ns, s.arrival_ns, s.data.data(), s.data.size()));
  CheckSql(sqlite3_step(insert_), db_, "INSERT INTO samples", path_);
  ++pending_;
}

void RecordingWriter::SetMeta(const std::string& key, const std::string& value) {
  Begin();
  Stmt st(db_, "INSERT OR REPLACE INTO meta(key, value) VALUES(?, ?)", path_);
  sqlite3_bind_text(st.s, 1, key.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_text(st.s, 2, value.c_str(), -1, SQLITE_TRANSIENT);
  CheckSql(sqlite3_step(st.s), db_, "INSERT INTO meta", path_);
}

void RecordingWriter::Commit() {
  if (!in_txn_) return;
  Exec(db_, "COMMIT", path_);
  in_txn_ = false;
  committed_ += pending_;
  pending_ = 0;
}

RecordingReader::RecordingReader(const std::string& path) : path_(path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw RecordingError(path + ": no such recording (not a file)");
  if (std::filesystem::file_size(path, ec) == 0) throw RecordingError(path + ": empty file, not a hullpipe recording");
  // Read-only: reading never changes the file. A killed writer's WAL is still
  // read (SQLite reads the log of a read-only connection; nothing is checkpointed).
  db_ = Open(path, SQLITE_OPEN_READONLY);
  try {
    auto not_ours = [&](const std::string& why) { return RecordingError(path_ + ": not a hullpipe recording (" + why + ")"); };
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
    Stmt fmt(db_, "SELECT value FROM meta WHERE key = 'format'", path_);
    if (sqlite3_step(fmt.s) != SQLITE_ROW) throw not_ours("no meta 'format'");
    const char* f = Text(fmt.s, 0);
    if (!f) throw not_ours("meta 'format' is NULL");
    if (std::string(f) != kFormat && std::string(f) != kFormatNoCrc)
      throw not_ours("format '" + std::string(f) + "'; this build reads " + kFormat + " and " + kFormatNoCrc);
    has_crc_ = std::string(f) == kFormat;
    {
      // The columns the reader selects, so a table of the wrong shape is named
      // here rather than failing in the middle of a replay.
      const char* sql = has_crc_ ? "SELECT topic_id, source_ns, arrival_ns, data, crc FROM samples LIMIT 0"
                                 : "SELECT topic_id, source_ns, arrival_ns, data FROM samples LIMIT 0";
      sqlite3_stmt* st = nullptr;
      const int rc = sqlite3_prepare_v2(db_, sql, -1, &st, nullptr);
      const std::string msg = sqlite3_errmsg(db_);
      sqlite3_finalize(st);
      if (rc != SQLITE_OK) throw not_ours("table 'samples': " + msg);
    }
    Stmt st(db_, "SELECT id, name, type, keyed, reliable, transient_local, depth FROM topics ORDER BY id", path_);
    int rc;
    while ((rc = sqlite3_step(st.s)) == SQLITE_ROW) {
      TopicInfo t;
      t.id = sqlite3_column_int64(st.s, 0);
      const char* name = Text(st.s, 1);
      const char* type = Text(st.s, 2);
      if (!name || !type)
        throw RecordingError(path_ + ": topics row " + std::to_string(t.id) + " has no " + (name ? "type" : "name"));
      t.name = name;
      t.type = type;
      t.keyed = sqlite3_column_int(st.s, 3);
      t.reliable = sqlite3_column_int(st.s, 4);
      t.transient_local = sqlite3_column_int(st.s, 5);
      t.depth = sqlite3_column_int(st.s, 6);
      topics_.push_back(t);
    }
    CheckSql(rc, db_, "SELECT FROM topics", path_);
  } catch (...) {
    sqlite3_close(db_);
    throw;
  }
}

RecordingReader::~RecordingReader() { sqlite3_close(db_); }

void RecordingReader::ForEach(const std::function<bool(const Sample&)>& f,
                              const std::optional<std::vector<int64_t>>& topic_ids) const {
  Stmt st(db_,
          has_crc_ ? "SELECT topic_id, source_ns, arrival_ns, data, crc FROM samples ORDER BY arrival_ns, id"
                   : "SELECT topic_id, source_ns, arrival_ns, data, NULL FROM samples ORDER BY arrival_ns, id",
          path_);
  std::set<int64_t> known;
  for (const auto& t : topics_) known.insert(t.id);
  Sample s;
  int rc;
  while ((rc = sqlite3_step(st.s)) == SQLITE_ROW) {
    s.topic_id = sqlite3_column_int64(st.s, 0);
    if (topic_ids && std::find(topic_ids->begin(), topic_ids->end(), s.topic_id) == topic_ids->end()) continue;
    s.source_ns = sqlite3_column_int64(st.s, 1);
    s.arrival_ns = sqlite3_column_int64(st.s, 2);
    const auto* p = static_cast<const uint8_t*>(sqlite3_column_blob(st.s, 3));
    const int n = sqlite3_column_bytes(st.s, 3);
    if (p) s.data.assign(p, p + n);
    else s.data.clear();
    if (!known.count(s.topic_id) ||
        (has_crc_ && (sqlite3_column_type(st.s, 4) != SQLITE_INTEGER ||
                      uint32_t(sqlite3_column_int64(st.s, 4)) !=
                          RowCrc(s.topic_id, s.source_ns, s.arrival_ns, s.data.data(), s.data.size())))) {
      ++damaged_;
      continue;
    }
    if (!f(s)) return;
  }
  CheckSql(rc, db_, "SELECT FROM samples", path_);
}

std::optional<int64_t> RecordingReader::LastArrivalNs(const std::optional<std::vector<int64_t>>& topic_ids) const {
  std::string sql = "SELECT MAX(arrival_ns) FROM samples";
  if (topic_ids) {
    sql += " WHERE topic_id IN (";
    for (size_t i = 0; i < topic_ids->size(); ++i) sql += (i ? "," : "") + std::to_string((*topic_ids)[i]);
    sql += ")";
  }
  Stmt st(db_, sql.c_str(), path_);
  CheckSql(sqlite3_step(st.s), db_, "SELECT MAX", path_);
  if (sqlite3_column_type(st.s, 0) == SQLITE_NULL) return std::nullopt;
  return sqlite3_column_int64(st.s, 0);
}

std::string RecordingReader::QuickCheck() const {
  Stmt st(db_, "PRAGMA quick_check(10)", path_);
  std::string out;
  int rc;
  while ((rc = sqlite3_step(st.s)) == SQLITE_ROW) {
    const char* line = Text(st.s, 0);
    if (line && std::string(line) == "ok") continue;
    out += (out.empty() ? "" : "; ") + std::string(line ? line : "?");
  }
  if (rc != SQLITE_DONE) out += (out.empty() ? "" : "; ") + std::string(sqlite3_errmsg(db_));
  return out;
}

RecordingInfo RecordingReader::Info() const {
  RecordingInfo info;
  info.damage = QuickCheck();
  try {
    Counts(&info);
  } catch (const RecordingError& e) {  // a damaged file: the counts so far
    info.damage += (info.damage.empty() ? "" : "; ") + std::string(e.what());
  }
  // Files of format 1 were closed by the recorder tool, which set stopped_ns.
  info.interrupted = !info.meta.count("closed_ns") && !info.meta.count("stopped_ns");
  // Every sample's CRC (and samples of no known topic).
  const int64_t before = damaged_;
  try {
    ForEach([](const Sample&) { return true; });
  } catch (const RecordingError& e) {
    info.damage += (info.damage.empty() ? "" : "; ") + std::string(e.what());
  }
  info.damaged_samples = damaged_ - before;
  if (info.damaged_samples > 0)
    info.damage += (info.damage.empty() ? "" : "; ") + std::to_string(info.damaged_samples) +
                   " sample(s) whose row does not match its CRC-32 or whose topic is unknown";
  return info;
}

void RecordingReader::Counts(RecordingInfo* out) const {
  RecordingInfo& info = *out;
  for (const auto& t : topics_) {
    RecordingInfo::TopicSummary ts;
    ts.topic = t;
    Stmt st(db_, "SELECT COUNT(*), COALESCE(SUM(LENGTH(data)), 0) FROM samples WHERE topic_id = ?", path_);
    sqlite3_bind_int64(st.s, 1, t.id);
    CheckSql(sqlite3_step(st.s), db_, "SELECT COUNT", path_);
    ts.count = sqlite3_column_int64(st.s, 0);
    ts.bytes = sqlite3_column_int64(st.s, 1);
    info.samples += ts.count;
    info.bytes += ts.bytes;
    info.topics.push_back(ts);
  }
  Stmt range(db_, "SELECT COALESCE(MIN(arrival_ns), 0), COALESCE(MAX(arrival_ns), 0) FROM samples", path_);
  CheckSql(sqlite3_step(range.s), db_, "SELECT MIN", path_);
  info.first_arrival_ns = sqlite3_column_int64(range.s, 0);
  info.last_arrival_ns = sqlite3_column_int64(range.s, 1);
  Stmt meta(db_, "SELECT key, value FROM meta", path_);
  while (sqlite3_step(meta.s) == SQLITE_ROW) {
    const char* k = Text(meta.s, 0);
    const char* v = Text(meta.s, 1);
    if (k) info.meta[k] = v ? v : "";
  }
}

bool TopicMatches(const std::string& pattern, const std::string& name) {
  return fnmatch(pattern.c_str(), name.c_str(), 0) == 0;
}

bool TopicSelected(const std::vector<std::string>& include, const std::vector<std::string>& exclude,
                   const std::string& name) {
  bool in = include.empty();
  for (const auto& p : include) in = in || TopicMatches(p, name);
  for (const auto& p : exclude)
    if (TopicMatches(p, name)) return false;
  return in;
}

}  // namespace hullpipe::record
