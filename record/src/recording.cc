#include "hullpipe/record/recording.h"

#include <fnmatch.h>
#include <sqlite3.h>

#include <filesystem>

namespace hullpipe::record {
namespace {

void CheckSql(int rc, sqlite3* db, const char* call, const std::string& path) {
  if (rc == SQLITE_OK || rc == SQLITE_DONE || rc == SQLITE_ROW) return;
  throw RecordingError(path + ": " + call + ": " + (db ? sqlite3_errmsg(db) : sqlite3_errstr(rc)));
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
  CheckSql(sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr), db_,
           "sqlite3_open_v2", path);
  // WAL: a commit is durable once its frames are in the log; a killed writer
  // leaves the log, which the next open replays up to the last commit.
  Exec(db_, "PRAGMA journal_mode=WAL", path_);
  Exec(db_, "PRAGMA synchronous=NORMAL", path_);
  Exec(db_,
       "CREATE TABLE meta(key TEXT PRIMARY KEY, value TEXT);"
       "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT UNIQUE NOT NULL, type TEXT NOT NULL,"
       " keyed INTEGER, reliable INTEGER, transient_local INTEGER, depth INTEGER);"
       "CREATE TABLE samples(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, source_ns INTEGER,"
       " arrival_ns INTEGER, data BLOB);"
       "INSERT INTO meta VALUES('format', 'hullpipe-recording-1');",
       path_);
  CheckSql(sqlite3_prepare_v2(db_, "INSERT INTO samples(topic_id, source_ns, arrival_ns, data) VALUES(?,?,?,?)", -1,
                              &insert_, nullptr),
           db_, "sqlite3_prepare_v2", path_);
}

RecordingWriter::~RecordingWriter() {
  try {
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
  if (!std::filesystem::exists(path)) throw RecordingError(path + ": no such recording");
  // Read-write open so a killed writer's WAL is replayed into view; nothing is written.
  CheckSql(sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE, nullptr), db_, "sqlite3_open_v2", path);
  try {
    Stmt fmt(db_, "SELECT value FROM meta WHERE key = 'format'", path_);
    if (sqlite3_step(fmt.s) != SQLITE_ROW ||
        std::string(reinterpret_cast<const char*>(sqlite3_column_text(fmt.s, 0))) != "hullpipe-recording-1")
      throw RecordingError(path_ + ": not a hullpipe recording");
    Stmt st(db_, "SELECT id, name, type, keyed, reliable, transient_local, depth FROM topics ORDER BY id", path_);
    while (sqlite3_step(st.s) == SQLITE_ROW) {
      TopicInfo t;
      t.id = sqlite3_column_int64(st.s, 0);
      t.name = reinterpret_cast<const char*>(sqlite3_column_text(st.s, 1));
      t.type = reinterpret_cast<const char*>(sqlite3_column_text(st.s, 2));
      t.keyed = sqlite3_column_int(st.s, 3);
      t.reliable = sqlite3_column_int(st.s, 4);
      t.transient_local = sqlite3_column_int(st.s, 5);
      t.depth = sqlite3_column_int(st.s, 6);
      topics_.push_back(t);
    }
  } catch (...) {
    sqlite3_close(db_);
    throw;
  }
}

RecordingReader::~RecordingReader() { sqlite3_close(db_); }

void RecordingReader::ForEach(const std::function<bool(const Sample&)>& f,
                              const std::optional<std::vector<int64_t>>& topic_ids) const {
  Stmt st(db_, "SELECT topic_id, source_ns, arrival_ns, data FROM samples ORDER BY arrival_ns, id", path_);
  Sample s;
  int rc;
  while ((rc = sqlite3_step(st.s)) == SQLITE_ROW) {
    s.topic_id = sqlite3_column_int64(st.s, 0);
    if (topic_ids && std::find(topic_ids->begin(), topic_ids->end(), s.topic_id) == topic_ids->end()) continue;
    s.source_ns = sqlite3_column_int64(st.s, 1);
    s.arrival_ns = sqlite3_column_int64(st.s, 2);
    const auto* p = static_cast<const uint8_t*>(sqlite3_column_blob(st.s, 3));
    s.data.assign(p, p + sqlite3_column_bytes(st.s, 3));
    if (!f(s)) return;
  }
  CheckSql(rc, db_, "SELECT FROM samples", path_);
}

RecordingInfo RecordingReader::Info() const {
  RecordingInfo info;
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
  while (sqlite3_step(meta.s) == SQLITE_ROW)
    info.meta[reinterpret_cast<const char*>(sqlite3_column_text(meta.s, 0))] =
        reinterpret_cast<const char*>(sqlite3_column_text(meta.s, 1));
  return info;
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
