#include "hullpipe/record/recording.h"

#include <fnmatch.h>
#include <sqlite3.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
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

}  // namespace

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

namespace {

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

int64_t FileBytes(const std::string& path) {
  std::error_code ec;
  int64_t n = 0;
  for (const std::string& p : {path, path + "-wal"}) {
    const auto size = std::filesystem::file_size(p, ec);
    if (!ec) n += int64_t(size);
  }
  return n;
}

}  // namespace

const char* CompressionName(Compression c) { return c == Compression::kZstd ? "zstd" : "none"; }

Compression ParseCompression(const std::string& name) {
  if (name == "none") return Compression::kNone;
  if (name == "zstd") return Compression::kZstd;
  throw std::invalid_argument("--compression must be none or zstd, not '" + name + "'");
}

void WriterOptions::Check() const {
  if (zstd_level < 1 || zstd_level > 19) throw std::invalid_argument("--zstd-level must be in [1, 19]");
}

bool DecodeSampleData(const uint8_t* data, size_t n, int codec, int64_t size, std::vector<uint8_t>* out) {
  if (codec == 0) {
    out->assign(data, data + n);
    return true;
  }
  if (codec != 1 || size < 0 || size > kMaxSampleBytes) return false;
  const unsigned long long declared = ZSTD_getFrameContentSize(data, n);
  if (declared != (unsigned long long)size) return false;
  out->resize(size_t(size));
  const size_t got = ZSTD_decompress(out->data(), out->size(), data, n);
  return !ZSTD_isError(got) && got == size_t(size);
}

RecordingWriter::RecordingWriter(const std::string& path, const WriterOptions& options)
    : options_(options), path_(path) {
  options_.Check();
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
    CheckSql(sqlite3_prepare_v2(
                 db_, "INSERT INTO samples(topic_id, source_ns, arrival_ns, data, crc, codec, size) VALUES(?,?,?,?,?,?,?)",
                 -1, &insert_, nullptr),
             db_, "sqlite3_prepare_v2", path_);
    if (options_.compression == Compression::kZstd) {
      zstd_ = ZSTD_createCCtx();
      if (!zstd_) throw RecordingError(path_ + ": ZSTD_createCCtx failed");
      ZSTD_CCtx_setParameter(static_cast<ZSTD_CCtx*>(zstd_), ZSTD_c_compressionLevel, options_.zstd_level);
    }
  } catch (...) {
    sqlite3_finalize(insert_);
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
  ZSTD_freeCCtx(static_cast<ZSTD_CCtx*>(zstd_));
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

void RecordingWriter::Append(const Sample& s) {
  const uint32_t crc = RowCrc(s.topic_id, s.source_ns, s.arrival_ns, s.data.data(), s.data.size());
  if (zstd_) {
    scratch_.resize(ZSTD_compressBound(s.data.size()));
    const size_t n = ZSTD_compress2(static_cast<ZSTD_CCtx*>(zstd_), scratch_.data(), scratch_.size(),
                                    s.data.data(), s.data.size());
    if (ZSTD_isError(n)) throw RecordingError(path_ + ": ZSTD_compress2: " + ZSTD_getErrorName(n));
    if (n < s.data.size()) {
      scratch_.resize(n);
      AppendEncoded(s.topic_id, s.source_ns, s.arrival_ns, scratch_, 1, int64_t(s.data.size()), crc);
      return;
    }
  }
  AppendEncoded(s.topic_id, s.source_ns, s.arrival_ns, s.data, 0, int64_t(s.data.size()), crc);
}

void RecordingWriter::AppendEncoded(int64_t topic_id, int64_t source_ns, int64_t arrival_ns,
                                    const std::vector<uint8_t>& data, int codec, int64_t size, uint32_t crc) {
  Begin();
  sqlite3_reset(insert_);
  sqlite3_bind_int64(insert_, 1, topic_id);
  sqlite3_bind_int64(insert_, 2, source_ns);
  sqlite3_bind_int64(insert_, 3, arrival_ns);
  sqlite3_bind_blob64(insert_, 4, data.data(), data.size(), SQLITE_STATIC);
  sqlite3_bind_int64(insert_, 5, crc);
  sqlite3_bind_int(insert_, 6, codec);
  sqlite3_bind_int64(insert_, 7, size);
  CheckSql(sqlite3_step(insert_), db_, "INSERT INTO samples", path_);
  ++pending_;
  stored_bytes_ += int64_t(data.size());
  raw_bytes_ += size;
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

// One file of a recording.
struct RecordingReader::Part {
  std::string path;
  sqlite3* db = nullptr;
  int format = 3;  // 1, 2 or 3
  std::vector<TopicInfo> topics;           // as in the file
  std::map<int64_t, int64_t> to_set_id;    // file topic id -> reader's topic id
  std::map<std::string, std::string> meta;
  ~Part() { sqlite3_close(db); }
};

RecordingReader::RecordingReader(const std::string& path) : path_(path) {
  std::error_code ec;
  std::vector<std::string> files;
  if (std::filesystem::is_directory(path, ec)) {
    for (const auto& e : std::filesystem::directory_iterator(path, ec))
      if (e.path().extension() == ".hprec" && e.is_regular_file(ec)) files.push_back(e.path().string());
    if (files.empty()) throw RecordingError(path + ": a directory without .hprec files, not a hullpipe recording");
    std::sort(files.begin(), files.end());
  } else {
    files.push_back(path);
  }
  for (const auto& f : files) parts_.push_back(OpenPart(f));
  if (parts_.size() > 1) {
    // One split recording: one set id, parts numbered without repeats, in order.
    std::map<int64_t, std::unique_ptr<Part>> by_index;
    std::set<std::string> sets;
    for (auto& p : parts_) {
      sets.insert(p->meta.count("set") ? p->meta.at("set") : "(none: " + p->path + ")");
      int64_t index = -1;
      try {
        index = std::stoll(p->meta.count("part") ? p->meta.at("part") : "-1");
      } catch (const std::exception&) {
      }
      if (index < 0) throw RecordingError(p->path + ": no meta 'part'; " + path + " holds files of several recordings");
      if (by_index.count(index))
        throw RecordingError(path + ": two files of part " + std::to_string(index) + " (" + by_index[index]->path +
                             ", " + p->path + ")");
      by_index[index] = std::move(p);
    }
    if (sets.size() > 1)
      throw RecordingError(path + ": holds files of " + std::to_string(sets.size()) +
                           " recordings (meta 'set'); give one file");
    parts_.clear();
    int64_t expect = 0;
    for (auto& [index, p] : by_index) {
      for (; expect < index; ++expect)
        missing_parts_ += (missing_parts_.empty() ? "" : ", ") + ("part " + std::to_string(expect) + " missing");
      ++expect;
      parts_.push_back(std::move(p));
    }
  }
  // The reader's topics: each name once, with the id of the part it first
  // appears in unless another name took that id.
  std::set<int64_t> used;
  std::map<std::string, int64_t> by_name;
  for (auto& p : parts_) {
    for (const auto& t : p->topics) {
      auto it = by_name.find(t.name);
      if (it == by_name.end()) {
        TopicInfo mine = t;
        if (used.count(mine.id)) mine.id = *used.rbegin() + 1;
        used.insert(mine.id);
        it = by_name.emplace(t.name, mine.id).first;
        topics_.push_back(mine);
      }
      p->to_set_id[t.id] = it->second;
    }
  }
}

RecordingReader::~RecordingReader() = default;

std::vector<std::string> RecordingReader::files() const {
  std::vector<std::string> out;
  for (const auto& p : parts_) out.push_back(p->path);
  return out;
}

std::unique_ptr<RecordingReader::Part> RecordingReader::OpenPart(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw RecordingError(path + ": no such recording (not a file)");
  if (std::filesystem::file_size(path, ec) == 0) throw RecordingError(path + ": empty file, not a hullpipe recording");
  auto part = std::make_unique<Part>();
  part->path = path;
  // Read-only: reading never changes the file. A killed writer's WAL is still
  // read (SQLite reads the log of a read-only connection; nothing is checkpointed).
  part->db = Open(path, SQLITE_OPEN_READONLY);
  sqlite3* db = part->db;
  auto not_ours = [&](const std::string& why) { return RecordingError(path + ": not a hullpipe recording (" + why + ")"); };
  std::set<std::string> tables;
  {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db, "SELECT name FROM sqlite_master WHERE type = 'table'", -1, &st, nullptr) != SQLITE_OK) {
      const std::string msg = sqlite3_errmsg(db);
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
    Stmt meta(db, "SELECT key, value FROM meta", path);
    int rc;
    while ((rc = sqlite3_step(meta.s)) == SQLITE_ROW) {
      const char* k = Text(meta.s, 0);
      const char* v = Text(meta.s, 1);
      if (k && !v && std::string(k) == "format") throw not_ours("meta 'format' is NULL");
      if (k) part->meta[k] = v ? v : "";
    }
    CheckSql(rc, db, "SELECT FROM meta", path);
  }
  if (!part->meta.count("format")) throw not_ours("no meta 'format'");
  const std::string f = part->meta.at("format");
  if (f == kFormat) part->format = 3;
  else if (f == kFormat2) part->format = 2;
  else if (f == kFormat1) part->format = 1;
  else throw not_ours("format '" + f + "'; this build reads " + kFormat + ", " + kFormat2 + " and " + kFormat1);
  {
    // The columns the reader selects, so a table of the wrong shape is named
    // here rather than failing in the middle of a replay.
    const char* sql = part->format == 3   ? "SELECT topic_id, source_ns, arrival_ns, data, crc, codec, size FROM samples LIMIT 0"
                      : part->format == 2 ? "SELECT topic_id, source_ns, arrival_ns, data, crc FROM samples LIMIT 0"
                                          : "SELECT topic_id, source_ns, arrival_ns, data FROM samples LIMIT 0";
    sqlite3_stmt* st = nullptr;
    const int rc = sqlite3_prepare_v2(db, sql, -1, &st, nullptr);
    const std::string msg = sqlite3_errmsg(db);
    sqlite3_finalize(st);
    if (rc != SQLITE_OK) throw not_ours("table 'samples': " + msg);
  }
  Stmt st(db,
          part->format == 3
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
    part->topics.push_back(t);
  }
  CheckSql(rc, db, "SELECT FROM topics", path);
  return part;
}

void RecordingReader::ForEach(const std::function<bool(const Sample&)>& f,
                              const std::optional<std::vector<int64_t>>& topic_ids) const {
  Sample s;
  for (const auto& p : parts_) {
    // The topic filter runs in SQL, so a replay of one topic reads no other's data.
    std::string where;
    if (topic_ids) {
      for (const auto& [file_id, set_id] : p->to_set_id)
        if (std::find(topic_ids->begin(), topic_ids->end(), set_id) != topic_ids->end())
          where += (where.empty() ? "" : ",") + std::to_string(file_id);
      if (where.empty()) continue;
      where = " WHERE topic_id IN (" + where + ")";
    }
    const std::string cols = p->format == 3   ? "topic_id, source_ns, arrival_ns, data, crc, codec, size"
                             : p->format == 2 ? "topic_id, source_ns, arrival_ns, data, crc, 0, -1"
                                              : "topic_id, source_ns, arrival_ns, data, NULL, 0, -1";
    const std::string sql = "SELECT " + cols + " FROM samples" + where + " ORDER BY arrival_ns, id";
    Stmt st(p->db, sql.c_str(), p->path);
    int rc;
    while ((rc = sqlite3_step(st.s)) == SQLITE_ROW) {
      const int64_t file_topic = sqlite3_column_int64(st.s, 0);
      const auto known = p->to_set_id.find(file_topic);
      s.topic_id = known == p->to_set_id.end() ? file_topic : known->second;
      s.source_ns = sqlite3_column_int64(st.s, 1);
      s.arrival_ns = sqlite3_column_int64(st.s, 2);
      const auto* data = static_cast<const uint8_t*>(sqlite3_column_blob(st.s, 3));
      const int n = sqlite3_column_bytes(st.s, 3);
      const int codec = sqlite3_column_int(st.s, 5);
      const int64_t size = sqlite3_column_int64(st.s, 6);
      bool ok = known != p->to_set_id.end();
      if (ok && codec == 0) {
        if (data) s.data.assign(data, data + n);
        else s.data.clear();
        ok = size < 0 || size == n;
      } else if (ok) {
        ok = data && DecodeSampleData(data, size_t(n), codec, size, &s.data);
      }
      // The CRC covers the file's own topic id, as written.
      if (ok && p->format >= 2)
        ok = sqlite3_column_type(st.s, 4) == SQLITE_INTEGER &&
             uint32_t(sqlite3_column_int64(st.s, 4)) ==
                 RowCrc(file_topic, s.source_ns, s.arrival_ns, s.data.data(), s.data.size());
      if (!ok) {
        ++damaged_;
        continue;
      }
      if (!f(s)) return;
    }
    CheckSql(rc, p->db, "SELECT FROM samples", p->path);
  }
}

std::optional<int64_t> RecordingReader::ArrivalBound(const char* fn,
                                                     const std::optional<std::vector<int64_t>>& topic_ids) const {
  std::optional<int64_t> out;
  const bool max = std::string(fn) == "MAX";
  for (const auto& p : parts_) {
    std::string sql = std::string("SELECT ") + fn + "(arrival_ns) FROM samples";
    if (topic_ids) {
      std::string ids;
      for (const auto& [file_id, set_id] : p->to_set_id)
        if (std::find(topic_ids->begin(), topic_ids->end(), set_id) != topic_ids->end())
          ids += (ids.empty() ? "" : ",") + std::to_string(file_id);
      if (ids.empty()) continue;
      sql += " WHERE topic_id IN (" + ids + ")";
    }
    Stmt st(p->db, sql.c_str(), p->path);
    CheckSql(sqlite3_step(st.s), p->db, fn, p->path);
    if (sqlite3_column_type(st.s, 0) == SQLITE_NULL) continue;
    const int64_t v = sqlite3_column_int64(st.s, 0);
    out = !out ? v : max ? std::max(*out, v) : std::min(*out, v);
  }
  return out;
}

std::optional<int64_t> RecordingReader::FirstArrivalNs(const std::optional<std::vector<int64_t>>& topic_ids) const {
  return ArrivalBound("MIN", topic_ids);
}

std::optional<int64_t> RecordingReader::LastArrivalNs(const std::optional<std::vector<int64_t>>& topic_ids) const {
  return ArrivalBound("MAX", topic_ids);
}

std::string RecordingReader::QuickCheck() const {
  std::string out;
  for (const auto& p : parts_) {
    Stmt st(p->db, "PRAGMA quick_check(10)", p->path);
    std::string mine;
    int rc;
    while ((rc = sqlite3_step(st.s)) == SQLITE_ROW) {
      const char* line = Text(st.s, 0);
      if (line && std::string(line) == "ok") continue;
      mine += (mine.empty() ? "" : "; ") + std::string(line ? line : "?");
    }
    if (rc != SQLITE_DONE) mine += (mine.empty() ? "" : "; ") + std::string(sqlite3_errmsg(p->db));
    if (!mine.empty()) out += (out.empty() ? "" : "; ") + (parts_.size() > 1 ? p->path + ": " : "") + mine;
  }
  return out;
}

RecordingInfo RecordingReader::Info() const {
  RecordingInfo info;
  info.damage = QuickCheck();
  if (!missing_parts_.empty()) info.damage += (info.damage.empty() ? "" : "; ") + missing_parts_;
  try {
    Counts(&info);
  } catch (const RecordingError& e) {  // a damaged file: the counts so far
    info.damage += (info.damage.empty() ? "" : "; ") + std::string(e.what());
  }
  // Files of format 1 were closed by the recorder tool, which set stopped_ns.
  const auto& last = parts_.back()->meta;
  info.interrupted = (!last.count("closed_ns") && !last.count("stopped_ns")) || last.count("interrupted");
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
                   " sample(s) whose row does not match its CRC-32, whose data does not decode, or whose topic is unknown";
  return info;
}

void RecordingReader::Counts(RecordingInfo* out) const {
  RecordingInfo& info = *out;
  std::map<int64_t, size_t> row;  // reader topic id -> index in info.topics
  for (const auto& t : topics_) {
    row[t.id] = info.topics.size();
    info.topics.push_back({t});
  }
  std::set<std::string> compressions;
  for (const auto& p : parts_) {
    info.files.push_back(p->path);
    info.file_bytes += FileBytes(p->path);
    for (const auto& [k, v] : p->meta) info.meta[k] = v;
    compressions.insert(p->meta.count("compression") ? p->meta.at("compression") : "none");
    const char* sql = p->format == 3
                          ? "SELECT topic_id, COUNT(*), COALESCE(SUM(CASE WHEN size >= 0 THEN size ELSE LENGTH(data) END), 0),"
                            " COALESCE(SUM(LENGTH(data)), 0) FROM samples GROUP BY topic_id"
                          : "SELECT topic_id, COUNT(*), COALESCE(SUM(LENGTH(data)), 0), COALESCE(SUM(LENGTH(data)), 0)"
                            " FROM samples GROUP BY topic_id";
    Stmt st(p->db, sql, p->path);
    int rc;
    while ((rc = sqlite3_step(st.s)) == SQLITE_ROW) {
      const auto id = p->to_set_id.find(sqlite3_column_int64(st.s, 0));
      if (id == p->to_set_id.end()) continue;  // rows of no topic: counted as damage by ForEach
      auto& ts = info.topics[row.at(id->second)];
      ts.count += sqlite3_column_int64(st.s, 1);
      ts.bytes += sqlite3_column_int64(st.s, 2);
      ts.stored_bytes += sqlite3_column_int64(st.s, 3);
    }
    CheckSql(rc, p->db, "SELECT COUNT", p->path);
  }
  for (auto& ts : info.topics) {
    info.samples += ts.count;
    info.bytes += ts.bytes;
    info.stored_bytes += ts.stored_bytes;
    const auto lost = info.meta.find("lost:" + ts.topic.name);
    if (lost != info.meta.end()) {
      try {
        ts.lost = std::stoll(lost->second);
      } catch (const std::exception&) {
      }
    }
  }
  info.first_arrival_ns = FirstArrivalNs().value_or(0);
  info.last_arrival_ns = LastArrivalNs().value_or(0);
  info.format = parts_.front()->meta.count("format") ? parts_.front()->meta.at("format") : "";
  for (const auto& c : compressions) info.compression += (info.compression.empty() ? "" : ", ") + c;
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
