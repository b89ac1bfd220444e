// hullpipe_record's work apart from its flags: recording a domain into a file,
// a split set or snapshots (the session), and the info and repair subcommands
// (docs/recording.md). Export and echo are record_export.h.
#pragma once

#include <string>
#include <vector>

#include "hullpipe/dds/node.h"
#include "hullpipe/record/recording.h"
#include "hullpipe/record/snapshot.h"
#include "hullpipe/record/split_writer.h"

namespace hullpipe::record {

/// What a recording session records, and how (hullpipe_record's flags).
struct RecordOptions {
  dds::CommonOptions common;
  std::string out;                  ///< -o: a file, or a directory for split sets and snapshots.
  std::string compression = "none"; ///< none, zstd or lz4 (MCAP only).
  std::string storage;              ///< sqlite or mcap; empty: by -o's extension (.mcap: MCAP).
  std::vector<std::string> include, exclude;  ///< Topic globs.
  double duration = 0;              ///< Seconds (0: until SIGINT).
  double batch_ms = 100;            ///< Commit at least this often.
  int depth = 256;                  ///< Reader history per instance.
  WriterOptions writer;
  SplitOptions split;
  SnapshotOptions snapshot;         ///< seconds 0: not snapshot mode.
  bool snapshot_bytes_given = false;  ///< --snapshot-bytes alone: a window by size.
};

/// Records until SIGINT/SIGTERM or the duration: topics discovered from
/// DCPSPublication, every hullpipe type's samples as serialized CDR in their
/// writers' order, committed in batches; snapshots on SIGUSR1 or a
/// RecordCommand. Returns 0; throws std::runtime_error / std::invalid_argument
/// naming the flag or file.
int RunRecord(const RecordOptions& options);

/// `info`: dates, size, format, topics, types, counts, losses (one JSON object
/// with json; each topic's IDL with idl). Returns the exit code.
int Info(const std::string& path, bool json, bool idl);

/// `repair`: what a killed recorder or a cut file holds, into a new recording.
int RepairCmd(const std::string& in, const std::string& out);

/// `convert`: a recording (either storage, one file or a split set) into a new
/// one in the storage `out`'s extension or `storage` names, every sample byte
/// for byte with its topic, QoS, IDL, times and the meta (plus 'converted_from');
/// then reads both and compares every sample's CRC-32. Returns the exit code
/// (3: the input is damaged or the copy differs).
int ConvertCmd(const std::string& in, const std::string& out, const std::string& storage,
               const std::string& compression, int zstd_level);

}  // namespace hullpipe::record
