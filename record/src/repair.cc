// Page-level salvage of SQLite files (https://www.sqlite.org/fileformat2.html:
// the database header, b-tree pages, cells, overflow pages, records, the WAL).
#include "hullpipe/record/repair.h"
#include "hullpipe/record/storage.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <memory>
#include <map>
#include <optional>
#include <set>
#include <variant>

namespace hullpipe::record {
namespace {

uint32_t Be(const uint8_t* p, int n) {
  uint32_t v = 0;
  for (int i = 0; i < n; ++i) v = (v << 8) | p[i];
  return v;
}

// A read-only mapping of a whole file (empty if it is missing or empty).
class Mapped {
 public:
  explicit Mapped(const std::string& path) {
    const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return;
    struct stat st {};
    if (fstat(fd, &st) == 0 && st.st_size > 0) {
      void* p = mmap(nullptr, size_t(st.st_size), PROT_READ, MAP_PRIVATE, fd, 0);
      if (p != MAP_FAILED) {
        data_ = static_cast<const char*>(p);
        size_ = size_t(st.st_size);
      }
    }
    close(fd);
  }
  ~Mapped() {
    if (data_) munmap(const_cast<char*>(data_), size_);
  }
  Mapped(const Mapped&) = delete;
  Mapped& operator=(const Mapped&) = delete;
  std::string_view view() const { return {data_ ? data_ : "", size_}; }

 private:
  const char* data_ = nullptr;
  size_t size_ = 0;
};

// A varint at p (at most 9 bytes, none past end); nullopt if it runs off the end.
std::optional<int64_t> Varint(const uint8_t*& p, const uint8_t* end) {
  uint64_t v = 0;
  for (int i = 0; i < 9; ++i) {
    if (p >= end) return std::nullopt;
    const uint8_t b = *p++;
    if (i == 8) return int64_t((v << 8) | b);
    v = (v << 7) | (b & 0x7f);
    if (!(b & 0x80)) return int64_t(v);
  }
  return std::nullopt;
}

using Value = std::variant<std::monostate, int64_t, double, std::string, std::vector<uint8_t>>;
enum Kind { kNull, kInt, kReal, kText, kBlob };
int KindOf(const Value& v) { return int(v.index()); }

// Decodes a record (header of serial types, then the values); nullopt if it is
// not one.
std::optional<std::vector<Value>> ParseRecord(const std::vector<uint8_t>& rec) {
  const uint8_t* p = rec.data();
  const uint8_t* end = p + rec.size();
  const auto header = Varint(p, end);
  if (!header || *header < 1 || *header > int64_t(rec.size())) return std::nullopt;
  const uint8_t* hend = rec.data() + *header;
  std::vector<int64_t> types;
  while (p < hend) {
    const auto t = Varint(p, hend);
    if (!t || *t < 0 || *t == 10 || *t == 11) return std::nullopt;
    types.push_back(*t);
  }
  const uint8_t* body = hend;
  std::vector<Value> out;
  for (int64_t t : types) {
    if (t == 0) {
      out.emplace_back(std::monostate{});
    } else if (t >= 1 && t <= 6) {
      static const int kBytes[] = {0, 1, 2, 3, 4, 6, 8};
      const int n = kBytes[t];
      if (end - body < n) return std::nullopt;
      uint64_t v = 0;
      for (int i = 0; i < n; ++i) v = (v << 8) | body[i];
      if (n < 8 && (body[0] & 0x80)) v |= ~uint64_t(0) << (8 * n);  // sign extension
      body += n;
      out.emplace_back(int64_t(v));
    } else if (t == 7) {
      if (end - body < 8) return std::nullopt;
      body += 8;
      out.emplace_back(0.0);
    } else if (t == 8 || t == 9) {
      out.emplace_back(int64_t(t - 8));
    } else {
      const int64_t n = (t - (t % 2 ? 13 : 12)) / 2;
      if (end - body < n) return std::nullopt;
      if (t % 2) out.emplace_back(std::string(body, body + n));
      else out.emplace_back(std::vector<uint8_t>(body, body + n));
      body += n;
    }
  }
  return out;
}

struct Pages {
  uint32_t page_size = 0, usable = 0;
  std::map<uint32_t, std::string_view> page;  // newest image of each page
  std::unique_ptr<Mapped> db_file, wal_file;
  std::string_view db, wal;
  int64_t wal_frames = 0;  ///< Log frames of the current salt, taken.
};

// The cell at `ptr` on leaf page `pg`: its rowid and its whole payload
// (following overflow pages); nullopt if any of it is missing.
std::optional<std::pair<int64_t, std::vector<uint8_t>>> Cell(const Pages& ps, std::string_view pg, uint32_t ptr) {
  const auto* base = reinterpret_cast<const uint8_t*>(pg.data());
  const uint8_t* end = base + pg.size();
  if (ptr >= pg.size()) return std::nullopt;
  const uint8_t* p = base + ptr;
  const auto size = Varint(p, end);
  const auto rowid = Varint(p, end);
  if (!size || !rowid || *size < 0 || *size > kMaxSampleBytes + (1 << 20)) return std::nullopt;
  const int64_t U = ps.usable, X = U - 35;
  int64_t local = *size;
  if (*size > X) {
    const int64_t M = ((U - 12) * 32 / 255) - 23;
    const int64_t K = M + ((*size - M) % (U - 4));
    local = K <= X ? K : M;
  }
  if (end - p < local) return std::nullopt;
  std::vector<uint8_t> payload(p, p + local);
  if (local < *size) {
    if (end - (p + local) < 4) return std::nullopt;
    uint32_t next = Be(p + local, 4);
    std::set<uint32_t> seen;
    while (int64_t(payload.size()) < *size) {
      if (next == 0 || !seen.insert(next).second) return std::nullopt;
      const auto it = ps.page.find(next);
      if (it == ps.page.end() || it->second.size() < ps.usable) return std::nullopt;
      const auto* o = reinterpret_cast<const uint8_t*>(it->second.data());
      const int64_t take = std::min<int64_t>(U - 4, *size - int64_t(payload.size()));
      payload.insert(payload.end(), o + 4, o + 4 + take);
      next = Be(o, 4);
    }
  }
  return std::make_pair(*rowid, std::move(payload));
}

// Calls f(rowid, record, page, cell pointer) for every cell of every table leaf page.
template <typename F>
void ForEachLeafRow(const Pages& ps, F&& f) {
  for (const auto& [no, pg] : ps.page) {
    const size_t hdr = no == 1 ? 100 : 0;
    if (pg.size() < hdr + 8) continue;
    const auto* b = reinterpret_cast<const uint8_t*>(pg.data());
    if (b[hdr] != 0x0D) continue;  // table b-tree leaf
    const uint32_t cells = Be(b + hdr + 3, 2);
    for (uint32_t i = 0; i < cells; ++i) {
      const size_t at = hdr + 8 + 2 * i;
      if (at + 2 > pg.size()) break;
      const auto cell = Cell(ps, pg, Be(b + at, 2));
      if (!cell) {
        f(int64_t(-1), std::optional<std::vector<Value>>{}, pg, 0u);  // a row that ran into a missing page
        continue;
      }
      f(cell->first, ParseRecord(cell->second), pg, uint32_t(Be(b + at, 2)));
    }
  }
}

Pages LoadPages(const std::string& in) {
  Pages ps;
  ps.db_file = std::make_unique<Mapped>(in);
  ps.wal_file = std::make_unique<Mapped>(in + "-wal");
  ps.db = ps.db_file->view();
  ps.wal = ps.wal_file->view();
  const auto* d = reinterpret_cast<const uint8_t*>(ps.db.data());
  if (ps.db.size() >= 100 && ps.db.substr(0, 16) == std::string_view("SQLite format 3\0", 16)) {
    const uint32_t sz = Be(d + 16, 2);
    ps.page_size = sz == 1 ? 65536 : sz;
    ps.usable = ps.page_size - d[20];
  }
  const auto* w = reinterpret_cast<const uint8_t*>(ps.wal.data());
  const bool wal_ok = ps.wal.size() >= 32 && (Be(w, 4) & 0xfffffffe) == 0x377f0682;
  if (ps.page_size == 0 && wal_ok) {  // the file's header is gone: the log says
    ps.page_size = Be(w + 8, 4);
    ps.usable = ps.page_size;
  }
  if (ps.page_size < 512 || ps.page_size > 65536 || (ps.page_size & (ps.page_size - 1)))
    throw RecordingError(in + ": no SQLite page size in the file or its log; nothing to repair");
  for (size_t off = 0, no = 1; off < ps.db.size(); off += ps.page_size, ++no)
    ps.page[uint32_t(no)] = ps.db.substr(off, ps.page_size);
  if (wal_ok && Be(w + 8, 4) == ps.page_size) {
    const uint32_t salt1 = Be(w + 16, 4), salt2 = Be(w + 20, 4);
    for (size_t off = 32; off + 24 + ps.page_size <= ps.wal.size(); off += 24 + ps.page_size) {
      const uint8_t* fh = w + off;
      if (Be(fh + 8, 4) != salt1 || Be(fh + 12, 4) != salt2) break;  // a frame of an older log
      ps.page[Be(fh, 4)] = ps.wal.substr(off + 24, ps.page_size);
      ++ps.wal_frames;
    }
  }
  return ps;
}

bool IsInt(const std::vector<Value>& r, size_t i) { return i < r.size() && KindOf(r[i]) == kInt; }
bool IsText(const std::vector<Value>& r, size_t i) { return i < r.size() && KindOf(r[i]) == kText; }
int64_t Int(const std::vector<Value>& r, size_t i) { return std::get<int64_t>(r[i]); }
const std::string& Str(const std::vector<Value>& r, size_t i) { return std::get<std::string>(r[i]); }

// The repaired file's meta: the input's (but what its writer sets itself:
// format, compression, closed_ns), where it came from and when, and whether the
// input was interrupted (docs/recording.md, "Repair").
void CarryMeta(const std::map<std::string, std::string>& meta, const std::string& in, bool was_closed,
               RecordingWriter* w) {
  for (const auto& [k, v] : meta)
    if (k != "format" && k != "compression" && k != "closed_ns") w->SetMeta(k, v);
  w->SetMeta("repaired_from", in);
  w->SetMeta("repaired_ns", std::to_string(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                                std::chrono::system_clock::now().time_since_epoch())
                                                .count()));
  if (!was_closed) w->SetMeta("interrupted", "1");
}

}  // namespace

// What the storage's reader reads, copied in arrival order: for MCAP, a scan of
// its records where it has no footer (storage.h), every chunk that decompresses
// and matches its CRC.
RepairReport RepairByReading(const std::string& in, const std::string& out) {
  RepairReport report;
  const RecordingReader r(in);
  const RecordingInfo info = r.Info();
  report.format = info.format;
  report.was_closed = !info.interrupted;
  RecordingWriter w(out);
  CarryMeta(info.meta, in, report.was_closed, &w);
  std::map<int64_t, int64_t> new_id;
  for (const auto& t : r.topics()) new_id[t.id] = w.AddTopic(t);
  report.topics = int64_t(r.topics().size());
  Sample copy;
  r.ForEach([&](const Sample& s) {
    copy = s;
    copy.topic_id = new_id.at(s.topic_id);
    w.Append(copy);
    if (++report.samples % 256 == 0) w.Commit();
    return true;
  });
  w.Commit();
  report.bad_samples = r.damaged_samples();
  return report;
}

RepairReport Repair(const std::string& in, const std::string& out) {
  std::error_code ec;
  if (std::filesystem::is_directory(in, ec))
    throw RecordingError(in + ": a directory; repair each part of a split recording into a new directory");
  if (!std::filesystem::is_regular_file(in, ec) && !std::filesystem::is_regular_file(in + "-wal", ec))
    throw RecordingError(in + ": no such file");
  if (std::filesystem::exists(out, ec)) throw RecordingError(out + ": exists; recordings are never overwritten");
  const StorageKind& kind = StorageKindOfFile(in);
  return kind.repair ? kind.repair(in, out) : RepairByReading(in, out);
}

RepairReport RepairSqlitePages(const std::string& in, const std::string& out) {
  const Pages ps = LoadPages(in);
  RepairReport report;
  report.pages = int64_t(ps.page.size());
  report.wal_frames = ps.wal_frames;

  std::map<std::string, std::string> meta;
  std::map<int64_t, TopicInfo> topics;  // by the input's id
  // A sample found whole and checked; its data is read again from the page
  // when it is written, so the recording is not held in memory twice.
  struct Row {
    int64_t rowid, topic_id, source_ns, arrival_ns;
    std::string_view page;
    uint32_t ptr;
    int codec;
    int64_t size;
    uint32_t crc;
  };
  std::map<int64_t, Row> samples;  // by rowid: stale copies of a page give the same row
  ForEachLeafRow(ps, [&](int64_t rowid, const std::optional<std::vector<Value>>& rec, std::string_view page,
                         uint32_t ptr) {
    if (!rec) {
      ++report.incomplete_samples;
      return;
    }
    const auto& r = *rec;
    if (r.size() == 2 && IsText(r, 0) && (IsText(r, 1) || KindOf(r[1]) == kNull)) {  // meta
      meta[Str(r, 0)] = IsText(r, 1) ? Str(r, 1) : "";
    } else if ((r.size() == 7 || r.size() == 8) && KindOf(r[0]) == kNull && IsText(r, 1) && IsText(r, 2) &&
               IsInt(r, 3) && IsInt(r, 4) && IsInt(r, 5) && IsInt(r, 6)) {  // topics
      TopicInfo t;
      t.id = rowid;
      t.name = Str(r, 1);
      t.type = Str(r, 2);
      t.keyed = Int(r, 3);
      t.reliable = Int(r, 4);
      t.transient_local = Int(r, 5);
      t.depth = int32_t(Int(r, 6));
      if (r.size() == 8 && IsText(r, 7)) t.type_description = Str(r, 7);
      topics[rowid] = t;
    } else if (r.size() >= 5 && r.size() <= 8 && r.size() != 7 && KindOf(r[0]) == kNull && IsInt(r, 1) &&
               IsInt(r, 2) && IsInt(r, 3) && (KindOf(r[4]) == kBlob || KindOf(r[4]) == kNull)) {  // samples
      Row row{rowid, Int(r, 1), Int(r, 2), Int(r, 3), page, ptr, 0, -1, 0};
      std::vector<uint8_t> stored;
      if (KindOf(r[4]) == kBlob) stored = std::get<std::vector<uint8_t>>(r[4]);
      std::vector<uint8_t> own;
      bool ok = true;
      if (r.size() == 8) {  // format 3
        ok = IsInt(r, 5) && IsInt(r, 6) && IsInt(r, 7);
        if (ok) {
          row.crc = uint32_t(Int(r, 5));
          row.codec = int(Int(r, 6));
          row.size = Int(r, 7);
          ok = DecodeSampleData(stored.data(), stored.size(), row.codec, row.size, &own);
        }
      } else {
        own = stored;
        row.size = int64_t(own.size());
        row.crc = r.size() == 6 && IsInt(r, 5)
                      ? uint32_t(Int(r, 5))
                      : RowCrc(row.topic_id, row.source_ns, row.arrival_ns, own.data(), own.size());  // format 1
        ok = r.size() == 5 || IsInt(r, 5);
      }
      if (!ok || RowCrc(row.topic_id, row.source_ns, row.arrival_ns, own.data(), own.size()) != row.crc) {
        ++report.bad_samples;
        return;
      }
      samples[rowid] = std::move(row);
    }
  });

  report.format = meta.count("format") ? meta.at("format") : "";
  report.was_closed = meta.count("closed_ns") || meta.count("stopped_ns");
  RecordingWriter w(out);
  CarryMeta(meta, in, report.was_closed, &w);
  // Which compression the rows use is per row (codec); the file's meta says what
  // the input's writer was asked for.
  w.SetMeta("compression", meta.count("compression") ? meta.at("compression") : "none");
  std::map<int64_t, int64_t> new_id;
  for (const auto& [id, t] : topics) new_id[id] = w.AddTopic(t);
  report.topics = int64_t(topics.size());
  std::vector<const Row*> order;
  for (const auto& [rowid, row] : samples) order.push_back(&row);
  std::stable_sort(order.begin(), order.end(), [](const Row* a, const Row* b) {
    return a->arrival_ns != b->arrival_ns ? a->arrival_ns < b->arrival_ns : a->rowid < b->rowid;
  });
  int64_t batch = 0;
  for (const Row* row : order) {
    const auto id = new_id.find(row->topic_id);
    if (id == new_id.end()) {
      ++report.orphan_samples;
      continue;
    }
    const auto cell = Cell(ps, row->page, row->ptr);
    const auto rec = cell ? ParseRecord(cell->second) : std::nullopt;
    std::vector<uint8_t> stored;
    if (rec && KindOf((*rec)[4]) == kBlob) stored = std::get<std::vector<uint8_t>>((*rec)[4]);
    // The CRC covers the topic id: recomputed where the id changed.
    uint32_t crc = row->crc;
    if (id->second != row->topic_id) {
      std::vector<uint8_t> own;
      DecodeSampleData(stored.data(), stored.size(), row->codec, row->size, &own);
      crc = RowCrc(id->second, row->source_ns, row->arrival_ns, own.data(), own.size());
    }
    w.AppendEncoded({.topic_id = id->second, .source_ns = row->source_ns, .arrival_ns = row->arrival_ns,
                     .data = stored, .codec = row->codec, .size = row->size, .crc = crc});
    ++report.samples;
    if (++batch % 256 == 0) w.Commit();
  }
  w.Commit();
  return report;
}

}  // namespace hullpipe::record
