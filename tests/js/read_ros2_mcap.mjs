// Reads an MCAP file as ROS 2 data, with readers nobody in hullpipe wrote:
// @mcap/core's indexed reader (summary, every message), each channel's schema
// parsed as Foxglove parses `ros2msg` (@foxglove/rosmsg, ros2 mode) and every
// message decoded by Foxglove's ROS 2 deserializer
// (@foxglove/rosmsg2-serialization). Prints one JSON object on stdout:
//   { profile, channels: {topic: {count, decoded, schema, schemaEncoding,
//     messageEncoding, metadata: {key: value}}}, first: {topic: first message},
//     invalid: [first errors] }
// (typed arrays of more than 64 elements as their length). Exit 1 with the
// error on stderr where the file cannot be read.
// Usage: node read_ros2_mcap.mjs FILE.mcap
import { open } from "node:fs/promises";
import { McapIndexedReader } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import { decompress as zstdDecompress } from "fzstd";
import lz4 from "lz4js";

const decompressHandlers = {
  zstd: (buffer, size) => zstdDecompress(buffer, new Uint8Array(Number(size))),
  lz4: (buffer, size) => {
    const out = lz4.decompress(buffer, Number(size));
    return out instanceof Uint8Array ? out : Uint8Array.from(out);
  },
};

function plain(value) {
  return JSON.parse(
    JSON.stringify(value, (_k, v) => {
      if (typeof v === "bigint") return Number(v);
      if (ArrayBuffer.isView(v)) return v.length <= 64 ? Array.from(v, (x) => (typeof x === "bigint" ? Number(x) : x)) : { length: v.length };
      return v;
    }),
  );
}

async function main(path) {
  const handle = await open(path, "r");
  const size = BigInt((await handle.stat()).size);
  const readable = {
    size: async () => size,
    read: async (offset, length) => {
      const buf = new Uint8Array(Number(length));
      await handle.read(buf, 0, Number(length), Number(offset));
      return buf;
    },
  };
  const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
  const channels = {};
  const readers = new Map();
  const first = {};
  const invalid = [];
  for (const [id, ch] of reader.channelsById) {
    const schema = reader.schemasById.get(ch.schemaId);
    channels[ch.topic] = {
      count: 0,
      decoded: 0,
      schema: schema?.name ?? "",
      schemaEncoding: schema?.encoding ?? "",
      messageEncoding: ch.messageEncoding,
      metadata: Object.fromEntries(ch.metadata),
    };
    try {
      if (schema?.encoding !== "ros2msg") throw new Error(`schema encoding ${schema?.encoding}, not ros2msg`);
      const text = new TextDecoder().decode(schema.data);
      readers.set(id, new MessageReader(parse(text, { ros2: true })));
    } catch (e) {
      invalid.push(`${ch.topic}: ${e.message}`);
    }
  }
  for await (const m of reader.readMessages()) {
    const ch = reader.channelsById.get(m.channelId);
    const c = channels[ch.topic];
    c.count += 1;
    const r = readers.get(m.channelId);
    if (!r) continue;
    try {
      const decoded = r.readMessage(m.data);
      c.decoded += 1;
      if (!(ch.topic in first)) first[ch.topic] = plain(decoded);
    } catch (e) {
      if (invalid.length < 20) invalid.push(`${ch.topic}: ${e.message}`);
    }
  }
  await handle.close();
  process.stdout.write(JSON.stringify({ profile: reader.header.profile, channels, first, invalid }) + "\n");
}

main(process.argv[2]).catch((e) => {
  process.stderr.write(`read_ros2_mcap: ${e.stack ?? e}\n`);
  process.exit(1);
});
