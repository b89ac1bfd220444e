// Reads an MCAP file with readers nobody in hullpipe wrote (@mcap/core's stream
// reader, every record with CRCs checked, and its indexed reader, the summary and
// every message), decodes every message of every channel — cdr ones with
// Foxglove's OMG IDL parser and CDR deserializer, json ones of Foxglove's
// well-known schemas checked against Foxglove's own JSON Schemas
// (@foxglove/schemas, by ajv), their images' bytes checked for JPEG or PNG — and
// prints one JSON object on stdout:
//   { records: {opcode name: count}, statistics: {...}, channels: {topic: {count,
//     decoded, schema, schemaEncoding, messageEncoding, qos, first: the first
//     message decoded}}, metadata: {name: {...}},
//     cameraInfo: [first decoded CameraInfo per camera_id], invalid: [first errors] }
// Exit 1 with the error on stderr where any reader refuses the file.
// Usage: node read_mcap.mjs FILE.mcap
import { readFileSync } from "node:fs";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { parseIDL } from "@foxglove/omgidl-parser";
import { MessageReader } from "@foxglove/omgidl-serialization";
import { decompressHandlers, openReadable, plain } from "./mcap_common.mjs";
import Ajv from "ajv";
import * as foxgloveSchemas from "@foxglove/schemas/jsonschema.js";

async function main() {
  const path = process.argv[2];
  // 1. A linear read of every record, CRCs validated.
  const stream = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  stream.append(readFileSync(path));
  const records = {};
  for (let r; (r = stream.nextRecord()); ) records[r.type] = (records[r.type] ?? 0) + 1;
  if (!stream.done()) throw new Error(`${path}: the stream reader did not reach the end`);

  // 2. The indexed reader: summary, then every message by its index.
  const { readable, close } = await openReadable(path);
  const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
  const channels = {};
  const decoders = new Map();
  for (const [id, ch] of reader.channelsById) {
    const schema = reader.schemasById.get(ch.schemaId);
    channels[ch.topic] = {
      id,
      count: 0,
      decoded: 0,
      schema: schema?.name ?? "",
      schemaEncoding: schema?.encoding ?? "",
      messageEncoding: ch.messageEncoding,
      qos: ch.metadata.get("qos") ?? null,
    };
    if (schema && schema.encoding === "omgidl") {
      const text = new TextDecoder().decode(schema.data);
      decoders.set(id, new MessageReader(schema.name, parseIDL(text)));
    }
  }
  const ajv = new Ajv({ strict: false, allErrors: false });
  const validators = new Map();
  const invalid = [];
  const imageMagic = (b64, format) => {
    const head = Buffer.from(b64.slice(0, 16), "base64");
    if (format === "jpeg") return head[0] === 0xff && head[1] === 0xd8;
    if (format === "png") return head[1] === 0x50 && head[2] === 0x4e && head[3] === 0x47;
    return false;
  };
  const cameraInfo = new Map();
  let lastLogTime = -1n;
  let ordered = true;
  for await (const m of reader.readMessages()) {
    const ch = reader.channelsById.get(m.channelId);
    const c = channels[ch.topic];
    c.count += 1;
    if (m.logTime < lastLogTime) ordered = false;
    lastLogTime = m.logTime;
    if (ch.messageEncoding === "json") {
      const schema = reader.schemasById.get(ch.schemaId);
      const msg = JSON.parse(new TextDecoder().decode(m.data));
      const name = schema?.name ?? "";
      if (name.startsWith("foxglove.")) {
        let v = validators.get(name);
        if (!v) {
          const official = foxgloveSchemas[name.slice("foxglove.".length)];
          if (!official) throw new Error(`${path}: ${ch.topic}: no Foxglove schema named ${name}`);
          v = ajv.compile(official);
          validators.set(name, v);
        }
        if (!v(msg)) {
          if (invalid.length < 5) invalid.push({ topic: ch.topic, errors: v.errors });
          continue;
        }
        if (name === "foxglove.CompressedImage" && !imageMagic(msg.data, msg.format)) {
          if (invalid.length < 5) invalid.push({ topic: ch.topic, errors: `data is not ${msg.format}` });
          continue;
        }
      }
      c.decoded += 1;
      if (!c.first) c.first = typeof msg.data === "string" ? { ...msg, data: msg.data.length } : msg;
      continue;
    }
    const dec = decoders.get(m.channelId);
    if (!dec) continue;
    const msg = dec.readMessage(m.data);
    c.decoded += 1;
    if (!c.first) c.first = plain(msg);
    if (c.schema === "hullpipe::msg::CameraInfo" && !cameraInfo.has(msg.camera_id)) cameraInfo.set(msg.camera_id, plain(msg));
  }
  const metadata = {};
  for await (const md of reader.readMetadata()) metadata[md.name] = Object.fromEntries(md.metadata);
  await close();
  const stats = reader.statistics;
  process.stdout.write(
    JSON.stringify({
      records,
      statistics: stats
        ? { messageCount: Number(stats.messageCount), channelCount: stats.channelCount, chunkCount: stats.chunkCount }
        : null,
      chunkIndexes: reader.chunkIndexes.length,
      ordered,
      channels,
      metadata,
      cameraInfo: [...cameraInfo.values()],
      invalid,
    }) + "\n",
  );
}

main().catch((e) => {
  process.stderr.write(`${process.argv[2]}: ${e?.stack ?? e}\n`);
  process.exit(1);
});
