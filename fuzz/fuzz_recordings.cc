// libFuzzer: recording files (record/recording.h), SQLite and MCAP alike (the
// reader picks by the magic; seeds of both), as `hullpipe_record info` and
// `hullpipe_replay` open them: the reader, Info (quick_check or the MCAP record
// scan and chunk CRCs, and every sample's check), and every sample in arrival
// order; then `hullpipe_record repair` of the same bytes (SQLite's page salvage,
// MCAP's intact chunks). A bad file must end in RecordingError naming the
// file, never a crash or another exception.
#include <cstdio>

#include "fuzz_util.h"
#include "hullpipe/record/recording.h"
#include "hullpipe/record/repair.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  hullpipe::fuzz::InputFile file(data, size, ".hullrec");
  try {
    hullpipe::record::RecordingReader reader(file.path());
    reader.Info();
    reader.LastArrivalNs();
    size_t bytes = 0;
    reader.ForEach([&](const hullpipe::record::Sample& s) {
      bytes += s.data.size();
      return true;
    });
  } catch (const hullpipe::record::RecordingError&) {
  }
  const std::string repaired = file.path() + ".repaired";
  std::remove(repaired.c_str());
  try {
    hullpipe::record::Repair(file.path(), repaired);
  } catch (const hullpipe::record::RecordingError&) {
  }
  std::remove(repaired.c_str());
  std::remove((repaired + "-wal").c_str());
  std::remove((repaired + "-shm").c_str());
  return 0;
}
