// A Foxglove WebSocket client nobody in hullpipe wrote (@foxglove/ws-protocol's
// FoxgloveClient over the `ws` package) against hullpipe_bridge: connects, lists
// the advertised channels (also those advertised later), subscribes to the
// given topics, decodes each message until it has COUNT of each TOPIC — cdr
// channels with Foxglove's OMG IDL parser and CDR decoder, json channels checked
// against Foxglove's own JSON Schemas (@foxglove/schemas, by ajv) with their
// images' bytes checked for JPEG or PNG and measured —, unsubscribes, checks
// that nothing more arrives for 0.5 s (the positive control: messages did
// arrive before), and prints one JSON object on stdout:
//   { serverInfo, channels: [topics], got: {topic: n}, first: {topic: decoded},
//     afterUnsubscribe: n, status: [messages], invalid: [{topic, errors}] }
// (a compressed image's data is given as {format, bytes, width, height} from
// its JPEG or PNG header; a point cloud's as its byte count).
// Exit 1 with the error on stderr on a failure or after `timeout` seconds.
// Usage: node ws_client.mjs ws://127.0.0.1:PORT TIMEOUT_S TOPIC=COUNT [TOPIC=COUNT...]
import WebSocket from "ws";
import wsProtocol from "@foxglove/ws-protocol";
const { FoxgloveClient } = wsProtocol;
import { parseIDL } from "@foxglove/omgidl-parser";
import { MessageReader } from "@foxglove/omgidl-serialization";
import Ajv from "ajv";
import * as foxgloveSchemas from "@foxglove/schemas/jsonschema.js";
import { plain } from "./mcap_common.mjs";

const ajv = new Ajv({ strict: false, allErrors: false });
const invalid = [];

// Width and height from a JPEG's start-of-frame or a PNG's IHDR; null if neither.
function imageSize(bytes, format) {
  if (format === "png") {
    if (bytes.length < 24 || bytes[1] !== 0x50 || bytes[2] !== 0x4e || bytes[3] !== 0x47) return null;
    return { width: bytes.readUInt32BE(16), height: bytes.readUInt32BE(20) };
  }
  if (format !== "jpeg" || bytes[0] !== 0xff || bytes[1] !== 0xd8) return null;
  let i = 2;
  while (i + 9 < bytes.length) {
    if (bytes[i] !== 0xff) return null;
    const marker = bytes[i + 1];
    if (marker >= 0xc0 && marker <= 0xcf && marker !== 0xc4 && marker !== 0xc8 && marker !== 0xcc)
      return { width: bytes.readUInt16BE(i + 7), height: bytes.readUInt16BE(i + 5) };
    i += 2 + bytes.readUInt16BE(i + 2);
  }
  return null;
}

// A json channel's reader: the message parsed and checked against Foxglove's schema.
function jsonReader(topic, schemaName) {
  const official = schemaName.startsWith("foxglove.") ? foxgloveSchemas[schemaName.slice("foxglove.".length)] : null;
  if (schemaName.startsWith("foxglove.") && !official) fail(`${topic}: no Foxglove schema named ${schemaName}`);
  const validate = official ? ajv.compile(official) : () => true;
  return {
    readMessage(data) {
      const msg = JSON.parse(new TextDecoder().decode(data));
      if (!validate(msg)) {
        if (invalid.length < 5) invalid.push({ topic, errors: validate.errors });
        return null;
      }
      if (schemaName === "foxglove.CompressedImage") {
        const bytes = Buffer.from(msg.data, "base64");
        const size = imageSize(bytes, msg.format);
        if (!size) {
          if (invalid.length < 5) invalid.push({ topic, errors: `data is not ${msg.format}` });
          return null;
        }
        return { ...msg, data: { format: msg.format, bytes: bytes.length, ...size } };
      }
      if (typeof msg.data === "string") return { ...msg, data: Buffer.from(msg.data, "base64").length };
      return msg;
    },
  };
}

const [url, timeoutArg, ...wanted] = process.argv.slice(2);
const need = Object.fromEntries(wanted.map((w) => [w.slice(0, w.lastIndexOf("=")), Number(w.slice(w.lastIndexOf("=") + 1))]));
const topics = Object.keys(need);
const fail = (msg) => {
  process.stderr.write(`${url}: ${msg}\n`);
  process.exit(1);
};
setTimeout(() => fail(`timed out after ${timeoutArg} s: ${JSON.stringify(state())}`), Number(timeoutArg) * 1000);


let serverInfo = null;
let channels = [];
const subs = new Map(); // subscription id -> {topic, reader}
const got = {};
const first = {};
const status = [];
let unsubscribed = false;
let unsubscribedAt = 0;
let afterUnsubscribe = 0;
const state = () => ({ serverInfo, channels: channels.map((c) => c.topic), got, afterUnsubscribe, status, invalid });

const client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
client.on("error", (e) => fail(`error: ${e?.message ?? e}`));
client.on("serverInfo", (info) => (serverInfo = info));
client.on("status", (s) => status.push(s.message));
client.on("advertise", (list) => {
  channels = channels.concat(list);
  for (const topic of topics) {
    const ch = list.find((c) => c.topic === topic);
    if (!ch) continue;
    let reader;
    if (ch.encoding === "cdr" && ch.schemaEncoding === "omgidl") reader = new MessageReader(ch.schemaName, parseIDL(ch.schema));
    else if (ch.encoding === "json" && ch.schemaEncoding === "jsonschema") {
      if (JSON.parse(ch.schema).title !== ch.schemaName) fail(`${topic}: schema titled other than ${ch.schemaName}`);
      reader = jsonReader(topic, ch.schemaName);
    } else fail(`${topic}: ${ch.encoding}/${ch.schemaEncoding}`);
    subs.set(client.subscribe(ch.id), { topic, reader });
    got[topic] = 0;
  }
});
client.on("message", ({ subscriptionId, data }) => {
  const sub = subs.get(subscriptionId);
  if (!sub) fail(`a message of unknown subscription ${subscriptionId}`);
  if (unsubscribed) {
    // Messages already on their way when the unsubscribe left are not counted.
    if (Date.now() - unsubscribedAt > 200) afterUnsubscribe += 1;
    return;
  }
  const msg = sub.reader.readMessage(data);
  if (msg === null) return; // invalid: listed, not counted
  got[sub.topic] += 1;
  if (!(sub.topic in first)) first[sub.topic] = plain(msg);
  if (topics.every((t) => got[t] >= need[t])) {
    unsubscribed = true;
    unsubscribedAt = Date.now();
    for (const id of subs.keys()) client.unsubscribe(id);
    setTimeout(() => {
      process.stdout.write(JSON.stringify({ ...state(), first }) + "\n");
      client.close();
      process.exit(0);
    }, 700);
  }
});
