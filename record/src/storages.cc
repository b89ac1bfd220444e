// The registered storages (storage.h): the one place that names them. A new
// storage is a StorageWriter and a StorageReader and one entry here.
#include "hullpipe/record/storage.h"

#include <stdexcept>

namespace hullpipe::record {

const std::vector<StorageKind>& Storages() {
  static const std::vector<StorageKind> kinds = {
      {.id = Storage::kSqlite,
       .name = "sqlite",
       .extension = ".hprec",
       .compressions = {Compression::kNone, Compression::kZstd},
       .cdr_only = true,
       .probe = nullptr,  // every file MCAP's magic does not claim: the SQLite reader says what it is not
       .open_writer = OpenSqliteWriter,
       .open_reader = OpenSqliteReader,
       .repair = RepairSqlitePages},
      {.id = Storage::kMcap,
       .name = "mcap",
       .extension = ".mcap",
       .compressions = {Compression::kNone, Compression::kZstd, Compression::kLz4},
       .cdr_only = false,
       .probe = IsMcapFile,
       .open_writer = OpenMcapWriter,
       .open_reader = OpenMcapReader,
       .repair = nullptr},
  };
  return kinds;
}

const StorageKind& StorageKindOfFile(const std::string& path) {
  const StorageKind* fallback = nullptr;
  for (const StorageKind& k : Storages()) {
    if (!k.probe) {
      fallback = fallback ? fallback : &k;
    } else if (k.probe(path)) {
      return k;
    }
  }
  return fallback ? *fallback : Storages().front();
}

const StorageKind& StorageKindOf(Storage id) {
  for (const StorageKind& k : Storages())
    if (k.id == id) return k;
  throw std::logic_error("storage " + std::to_string(int(id)) + " is not registered");
}

}  // namespace hullpipe::record
