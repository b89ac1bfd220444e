// Reads an MCAP file as ROS 2 data, with readers nobody in hullpipe wrote:
// @mcap/core's indexed reader (summary, every message), each channel's schema
// parsed as Foxglove parses `ros2msg` (@foxglove/rosmsg, ros2 mode) and every
// message decoded by Foxglove's ROS 2 deserializer
// (@foxglove/rosmsg2-serialization). Prints one JSON object on stdout:
//   { profile, channels: {topic: {count, decoded, schema, schemaEncoding,
//     messageEncoding, metadata: {key: value}}}, first: {topic: first message},
//     frames: {topic: [every frame id its messages name, in order of first
//     appearance: header.frame_id, or /tf's child_frame_ids]},
//     invalid: [first errors] }
// (typed arrays of more than 64 elements as their length). Exit 1 with the
// error on stderr where the file cannot be read.
// Usage: node read_ros2_mcap.mjs FILE.mcap
import { McapIndexedReader } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import { decompressHandlers, openReadable, plain } from "./mcap_common.mjs";

async function main(path) {
  const { readable, close } = await openReadable(path);
  const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
  const channels = {};
  const readers = new Map();
  const first = {};
  const frames = {};
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
      const ids = (frames[ch.topic] ??= []);
      for (const id of [decoded.header?.frame_id, ...(decoded.transforms ?? []).map((t) => t.child_frame_id)])
        if (typeof id === "string" && !ids.includes(id)) ids.push(id);
    } catch (e) {
      if (invalid.length < 20) invalid.push(`${ch.topic}: ${e.message}`);
    }
  }
  await close();
  process.stdout.write(JSON.stringify({ profile: reader.header.profile, channels, first, frames, invalid }) + "\n");
}

main(process.argv[2]).catch((e) => {
  process.stderr.write(`read_ros2_mcap: ${e.stack ?? e}\n`);
  process.exit(1);
});
