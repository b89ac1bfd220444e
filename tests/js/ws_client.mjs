// A Foxglove WebSocket client nobody in hullpipe wrote (@foxglove/ws-protocol's
// FoxgloveClient over the `ws` package) against hullpipe_bridge: connects, lists
// the advertised channels, subscribes to the given topics, decodes each message
// with Foxglove's OMG IDL parser and CDR decoder until it has COUNT of each
// TOPIC, unsubscribes, checks that nothing more arrives for 0.5 s (the positive
// control: messages did arrive before), and prints one JSON object on stdout:
//   { serverInfo, channels: [topics], got: {topic: n}, first: {topic: decoded},
//     afterUnsubscribe: n, status: [messages] }
// Exit 1 with the error on stderr on a failure or after `timeout` seconds.
// Usage: node ws_client.mjs ws://127.0.0.1:PORT TIMEOUT_S TOPIC=COUNT [TOPIC=COUNT...]
import WebSocket from "ws";
import wsProtocol from "@foxglove/ws-protocol";
const { FoxgloveClient } = wsProtocol;
import { parseIDL } from "@foxglove/omgidl-parser";
import { MessageReader } from "@foxglove/omgidl-serialization";

const [url, timeoutArg, ...wanted] = process.argv.slice(2);
const need = Object.fromEntries(wanted.map((w) => [w.slice(0, w.lastIndexOf("=")), Number(w.slice(w.lastIndexOf("=") + 1))]));
const topics = Object.keys(need);
const fail = (msg) => {
  process.stderr.write(`${url}: ${msg}\n`);
  process.exit(1);
};
setTimeout(() => fail(`timed out after ${timeoutArg} s: ${JSON.stringify(state())}`), Number(timeoutArg) * 1000);

function plain(value) {
  return JSON.parse(
    JSON.stringify(value, (_k, v) => {
      if (typeof v === "bigint") return Number(v);
      if (ArrayBuffer.isView(v)) return v.length <= 64 ? Array.from(v, (x) => (typeof x === "bigint" ? Number(x) : x)) : { length: v.length };
      return v;
    }),
  );
}

let serverInfo = null;
let channels = [];
const subs = new Map(); // subscription id -> {topic, reader}
const got = {};
const first = {};
const status = [];
let unsubscribed = false;
let unsubscribedAt = 0;
let afterUnsubscribe = 0;
const state = () => ({ serverInfo, channels: channels.map((c) => c.topic), got, afterUnsubscribe, status });

const client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
client.on("error", (e) => fail(`error: ${e?.message ?? e}`));
client.on("serverInfo", (info) => (serverInfo = info));
client.on("status", (s) => status.push(s.message));
client.on("advertise", (list) => {
  channels = channels.concat(list);
  for (const topic of topics) {
    const ch = list.find((c) => c.topic === topic);
    if (!ch) continue;
    if (ch.encoding !== "cdr" || ch.schemaEncoding !== "omgidl") fail(`${topic}: ${ch.encoding}/${ch.schemaEncoding}`);
    const reader = new MessageReader(ch.schemaName, parseIDL(ch.schema));
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
