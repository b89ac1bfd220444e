// MCAP chunk compression (mcap_compression.h).
#include "mcap_compression.h"

#include <lz4frame.h>

#include <algorithm>
#include <memory>

#include "mcap_format.h"

namespace hullpipe::record::mcap {

bool Compress(Compression c, ZSTD_CCtx* zstd, const std::vector<uint8_t>& in, std::vector<uint8_t>* out,
              const std::string& path) {
  if (c == Compression::kZstd) {
    out->resize(ZSTD_compressBound(in.size()));
    const size_t n = ZSTD_compress2(zstd, out->data(), out->size(), in.data(), in.size());
    if (ZSTD_isError(n)) throw RecordingError(path + ": ZSTD_compress2: " + ZSTD_getErrorName(n));
    out->resize(n);
  } else if (c == Compression::kLz4) {
    LZ4F_preferences_t prefs{};
    prefs.frameInfo.contentSize = in.size();
    prefs.compressionLevel = 0;  // LZ4's fast default
    out->resize(LZ4F_compressFrameBound(in.size(), &prefs));
    const size_t n = LZ4F_compressFrame(out->data(), out->size(), in.data(), in.size(), &prefs);
    if (LZ4F_isError(n)) throw RecordingError(path + ": LZ4F_compressFrame: " + LZ4F_getErrorName(n));
    out->resize(n);
  } else {
    return false;
  }
  // A chunk that would compress past the readers' ratio rule is stored as it
  // is, so every file written reads back (recording.h, ZstdRatioPlausible).
  return out->size() < in.size() && ZstdRatioPlausible(out->size(), int64_t(in.size()));
}

bool Decompress(const std::string& compression, const uint8_t* p, size_t n, uint64_t size, std::vector<uint8_t>* out) {
  if (size > kMaxChunkBytes) return false;
  // A chunk of a few KB that truly gives gigabytes (run-length blocks): refused
  // by the ratio rule before anything is allocated.
  if (!compression.empty() && !ZstdRatioPlausible(n, int64_t(size))) return false;
  if (compression.empty()) {
    if (n != size) return false;
    out->assign(p, p + n);
    return true;
  }
  out->clear();
  size_t have = 0;
  auto grow = [&] {
    const size_t next = size_t(std::min<uint64_t>(size, std::max<uint64_t>(2 * out->size(), uint64_t(n) * 4 + 65536)));
    out->resize(next);
  };
  if (compression == "zstd") {
    std::unique_ptr<ZSTD_DCtx, size_t (*)(ZSTD_DCtx*)> d(ZSTD_createDCtx(), ZSTD_freeDCtx);
    ZSTD_inBuffer in{p, n, 0};
    while (true) {
      if (have == out->size()) {
        if (out->size() == size) {  // full: the frame must be over
          uint8_t probe;
          ZSTD_outBuffer o{&probe, 1, 0};
          const size_t r = ZSTD_decompressStream(d.get(), &o, &in);
          return !ZSTD_isError(r) && o.pos == 0 && r == 0 && in.pos == in.size;
        }
        grow();
      }
      ZSTD_outBuffer o{out->data(), out->size(), have};
      const size_t r = ZSTD_decompressStream(d.get(), &o, &in);
      if (ZSTD_isError(r)) return false;
      have = o.pos;
      if (r == 0) return have == size && in.pos == in.size;
      if (in.pos == in.size && o.pos < o.size) return false;  // input over, frame not
    }
  }
  if (compression == "lz4") {
    LZ4F_dctx* raw = nullptr;
    if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION))) return false;
    std::unique_ptr<LZ4F_dctx, size_t (*)(LZ4F_dctx*)> d(raw, LZ4F_freeDecompressionContext);
    size_t used = 0;
    while (true) {
      if (have == out->size()) {
        if (out->size() == size) {
          uint8_t probe;
          size_t dst = 1, src = n - used;
          const size_t r = LZ4F_decompress(d.get(), &probe, &dst, p + used, &src, nullptr);
          return !LZ4F_isError(r) && dst == 0 && r == 0 && used + src == n;
        }
        grow();
      }
      size_t dst = out->size() - have, src = n - used;
      const size_t r = LZ4F_decompress(d.get(), out->data() + have, &dst, p + used, &src, nullptr);
      if (LZ4F_isError(r)) return false;
      have += dst;
      used += src;
      if (r == 0) return have == size && used == n;
      if (dst == 0 && src == 0) return false;  // no progress: the frame is cut
    }
  }
  return false;  // a compression this build does not read
}

}  // namespace hullpipe::record::mcap
