// Repair of a recording a killed recorder or a damaged disk left behind
// (docs/recording.md), like rosbag2's `reindex`: reads the SQLite file and its WAL
// log page by page without SQLite's b-trees (which a file cut short no longer
// has), takes every meta, topic and sample row it can parse whole, keeps the
// samples whose CRC-32 matches (so no damaged or stale byte is taken for data),
// and writes them, in arrival order, to a new recording. The input is never
// modified.
#pragma once

#include <cstdint>
#include <string>

#include "hullpipe/record/recording.h"

namespace hullpipe::record {

/// What Repair found and wrote.
struct RepairReport {
  int64_t pages = 0;              ///< Pages read (file and log, whole or cut).
  int64_t wal_frames = 0;         ///< Log frames taken.
  int64_t topics = 0;             ///< Topic rows recovered.
  int64_t samples = 0;            ///< Samples written.
  int64_t bad_samples = 0;        ///< Sample rows found whose CRC-32 or frame did not check (not written).
  int64_t incomplete_samples = 0; ///< Sample rows whose data ran into a missing page (not written).
  int64_t orphan_samples = 0;     ///< Samples of a topic whose row was lost (not written).
  bool was_closed = false;        ///< The input's writer had closed it (meta closed_ns or stopped_ns).
  std::string format;             ///< The input's meta 'format' ("" if lost).
};

/// Recovers `in` (one file; its `-wal` beside it is read too) into the new
/// recording `out` (format 3, samples copied as stored; `out` ending .mcap: MCAP).
/// An MCAP `in` (no footer, a chunk cut in the middle) is read by a scan of its
/// records: every chunk that decompresses and matches its CRC-32 is kept, up to
/// the last intact one (pages and wal_frames are 0). The output's meta keeps
/// the input's (created_ns, domain, lost counts...) and adds 'repaired_from',
/// 'repaired_ns' and, if the input was not closed, 'interrupted' = "1", which
/// RecordingInfo::interrupted reports. Throws RecordingError if `in` cannot be
/// read at all (missing, or no SQLite page size in it or its log) or `out` exists.
RepairReport Repair(const std::string& in, const std::string& out);

}  // namespace hullpipe::record
