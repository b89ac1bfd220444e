// What the interoperability readers share (read_mcap.mjs, read_ros2_mcap.mjs,
// ws_client.mjs): the MCAP chunk codecs, a file as @mcap/core's readable, and
// the decoded messages as JSON.
import { open } from "node:fs/promises";
import { decompress as zstdDecompress } from "fzstd";
import lz4 from "lz4js";

/// @mcap/core's decompressHandlers for zstd and lz4 chunks.
export const decompressHandlers = {
  zstd: (buffer, size) => zstdDecompress(buffer, new Uint8Array(Number(size))),
  lz4: (buffer, size) => {
    const out = lz4.decompress(buffer, Number(size));
    return out instanceof Uint8Array ? out : Uint8Array.from(out);
  },
};

/// JSON for what a deserializer gives: bigints as numbers (ns fit in 2^53 for a
/// check), short typed arrays (K, poses) as arrays, long ones (images, runs) as
/// their length.
export function plain(value) {
  return JSON.parse(
    JSON.stringify(value, (_k, v) => {
      if (typeof v === "bigint") return Number(v);
      if (ArrayBuffer.isView(v)) return v.length <= 64 ? Array.from(v, (x) => (typeof x === "bigint" ? Number(x) : x)) : { length: v.length };
      return v;
    }),
  );
}

/// The file at `path` as @mcap/core's IReadable, and a close() for it.
export async function openReadable(path) {
  const handle = await open(path, "r");
  const size = BigInt((await handle.stat()).size);
  return {
    readable: {
      size: async () => size,
      read: async (offset, length) => {
        const buf = new Uint8Array(Number(length));
        await handle.read(buf, 0, Number(length), Number(offset));
        return buf;
      },
    },
    close: () => handle.close(),
  };
}
