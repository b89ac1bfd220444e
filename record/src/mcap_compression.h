// An MCAP chunk's compression (https://mcap.dev/spec, "Chunk": "zstd" and
// "lz4" frames, or "" for none), bounded as recording.h's ZstdRatioPlausible
// and mcap_format.h's kMaxChunkBytes say. Internal to the recording library.
#pragma once

#include <zstd.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "hullpipe/record/recording.h"

namespace hullpipe::record::mcap {

/// Compresses `in` by `c` (zstd with the context `zstd`, at its level; lz4 at
/// its fast default) into *out; false where `c` is none or it did not shrink
/// within the ratio rule (the chunk is then stored as it is). Throws
/// RecordingError naming `path` if the compressor fails.
bool Compress(Compression c, ZSTD_CCtx* zstd, const std::vector<uint8_t>& in, std::vector<uint8_t>* out,
              const std::string& path);

/// Decompresses n bytes at p, a chunk's records compressed by `compression`
/// ("zstd", "lz4" or "" for none), into *out, which must come to exactly `size`
/// bytes (at most kMaxChunkBytes, within the ratio rule). The buffer grows with
/// what really decompresses, so a size that lies costs no more memory than the
/// data it stands for. False on any mismatch or an unknown compression.
bool Decompress(const std::string& compression, const uint8_t* p, size_t n, uint64_t size, std::vector<uint8_t>* out);

}  // namespace hullpipe::record::mcap
