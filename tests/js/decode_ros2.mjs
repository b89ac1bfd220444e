// Decodes ROS 2 CDR messages with readers nobody in hullpipe wrote: Foxglove's
// ROS 2 deserializer (@foxglove/rosmsg2-serialization) with the ROS 2 Humble
// definitions Foxglove ships (@foxglove/rosmsg-msgs-common's ros2humble), not
// hullpipe's IDL. Reads lines "TYPE BASE64" on stdin (TYPE as
// "sensor_msgs/msg/CameraInfo"), prints one JSON line per message: the decoded
// fields (typed arrays as arrays, bigints as numbers), or {"error": "..."}.
// hullpipe's own hullpipe_msgs types are read from the ament package's .msg
// files (ros2/hullpipe_msgs/msg, the definitions a ROS 2 machine builds), parsed
// by Foxglove's .msg parser (@foxglove/rosmsg), not from hullpipe's IDL.
// Usage: node decode_ros2.mjs FILE
import { readFileSync } from "node:fs";
import { dirname, join } from "node:path";
import { fileURLToPath } from "node:url";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import { ros2humble } from "@foxglove/rosmsg-msgs-common";

const hullpipeMsgs = join(dirname(fileURLToPath(import.meta.url)), "../../ros2/hullpipe_msgs/msg");

// hullpipe_msgs/Type's root definition from its .msg file (complex fields left
// named, resolved against the Humble definitions).
function hullpipeDefinition(name) {
  const text = readFileSync(join(hullpipeMsgs, name.split("/")[1] + ".msg"), "utf8");
  const [root] = parse(text, { ros2: true, skipTypeFixup: true });
  return root;
}

// The definition of `name` ("sensor_msgs/CameraInfo") first, then every
// definition it may reference (the reader resolves complex fields by name).
function definitionsOf(name) {
  const root = name.startsWith("hullpipe_msgs/") ? hullpipeDefinition(name) : ros2humble[name];
  if (!root) throw new Error(`no ROS 2 Humble definition of ${name}`);
  const rest = Object.entries(ros2humble)
    .filter(([key]) => key !== name)
    .map(([key, def]) => ({ ...def, name: key }));
  return [{ ...root, name: undefined }, ...rest];
}

function plain(value) {
  if (typeof value === "bigint") return Number(value);
  if (ArrayBuffer.isView(value)) return Array.from(value, plain);
  if (Array.isArray(value)) return value.map(plain);
  if (value && typeof value === "object") {
    const out = {};
    for (const [k, v] of Object.entries(value)) out[k] = plain(v);
    return out;
  }
  return value;
}

const readers = new Map();
for (const line of readFileSync(process.argv[2], "utf8").split("\n")) {
  if (!line.trim()) continue;
  const [type, b64] = line.trim().split(/\s+/);
  try {
    const name = type.replace("/msg/", "/");
    if (!readers.has(name)) readers.set(name, new MessageReader(definitionsOf(name)));
    const bytes = Buffer.from(b64, "base64");
    const decoded = readers.get(name).readMessage(new Uint8Array(bytes.buffer, bytes.byteOffset, bytes.length));
    process.stdout.write(JSON.stringify(plain(decoded)) + "\n");
  } catch (e) {
    process.stdout.write(JSON.stringify({ error: String(e && e.message ? e.message : e) }) + "\n");
  }
}
