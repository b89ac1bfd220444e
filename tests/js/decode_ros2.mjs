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
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import { definitionsOf } from "./ros2_definitions.mjs";

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
