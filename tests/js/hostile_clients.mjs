// Hostile clients against a live hullpipe_bridge while a well-behaved one
// watches (docs/reliability.md, "Live view"). The good client subscribes to
// TOPIC and counts its messages for PHASE_S seconds alone, then for PHASE_S
// seconds while, at once:
//   - a flooder subscribes 20,000 times to the image channel in one message and
//     never reads again (its 19,999 refusals and its images must stay inside its
//     own queue bound);
//   - a non-reader subscribes to the images and never reads;
//   - a spammer sends 60 unknown operations of 16 KiB names and never reads;
//   - FLOOD handshakes start together and stay open if accepted.
// Prints one JSON object on stdout:
//   { alone, hostile (messages/s of the good client), floodOpened (handshakes
//     of the flood that opened), goodStatus: [status messages it got] }
// Usage: node hostile_clients.mjs ws://127.0.0.1:PORT TOPIC PHASE_S FLOOD
import WebSocket from "ws";

const [url, topic, phaseArg, floodArg] = process.argv.slice(2);
const phaseMs = Number(phaseArg) * 1000;
const flood = Number(floodArg);
const proto = ["foxglove.websocket.v1"];
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const fail = (why) => {
  console.error(why);
  process.exit(1);
};
setTimeout(() => fail("timed out"), phaseMs * 2 + 60000).unref();

// A client that resolves with its socket and the channels advertised to it.
function connect() {
  return new Promise((resolve, reject) => {
    const w = new WebSocket(url, proto);
    const channels = [];
    w.on("message", (d, bin) => {
      if (bin) return;
      const m = JSON.parse(d);
      if (m.op === "advertise") {
        channels.push(...m.channels);
        resolve({ w, channels });
      }
    });
    w.on("error", reject);
    w.on("unexpected-response", () => reject(new Error("refused")));
  });
}
const channelOf = (channels, t) => {
  const c = channels.find((c) => c.topic === t);
  if (!c) fail(`no channel ${t}`);
  return c.id;
};

const good = await connect();
let count = 0;
const goodStatus = [];
good.w.on("message", (d, bin) => {
  if (bin) count++;
  else {
    const m = JSON.parse(d);
    if (m.op === "status") goodStatus.push(m.message);
  }
});
good.w.send(JSON.stringify({ op: "subscribe", subscriptions: [{ id: 1, channelId: channelOf(good.channels, topic) }] }));
// The first message, not a fixed wait: the bridge makes its reader on the
// first subscription (the script's own time-out is the deadline).
while (count === 0) await sleep(20);
count = 0;
await sleep(phaseMs);
const alone = count / (phaseMs / 1000);

// The hostile ones.
const flooder = await connect();
const image = channelOf(flooder.channels, "hullpipe/camera_image");
const subs = [];
for (let k = 1; k <= 20000; k++) subs.push({ id: k, channelId: image });
flooder.w.send(JSON.stringify({ op: "subscribe", subscriptions: subs }));
flooder.w._socket.pause();
const nonReader = await connect();
nonReader.w.send(JSON.stringify({ op: "subscribe", subscriptions: [{ id: 1, channelId: image }] }));
setTimeout(() => nonReader.w._socket.pause(), 200);
const spammer = await connect();
spammer.w._socket.pause();
for (let k = 0; k < 60; k++) spammer.w.send(JSON.stringify({ op: "x".repeat(16384) + k }));
let floodOpened = 0;
const held = [];
for (let k = 0; k < flood; k++) {
  const w = new WebSocket(url, proto);
  w.on("open", () => {
    floodOpened++;
    held.push(w);
  });
  w.on("error", () => {});
  w.on("unexpected-response", () => {});
}
count = 0;
await sleep(phaseMs);
const hostile = count / (phaseMs / 1000);
console.log(JSON.stringify({ alone, hostile, floodOpened, goodStatus }));
process.exit(0);
