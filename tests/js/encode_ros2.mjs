// Encodes ROS 2 messages as a ROS 2 peer nobody in hullpipe wrote would put
// them on the wire: Foxglove's ROS 2 serializer (@foxglove/rosmsg2-serialization's
// MessageWriter, CDR with its 4-byte header) from the definitions of
// ros2_definitions.mjs (ROS 2 Humble's, and hullpipe_msgs' .msg files), not
// hullpipe's IDL. Reads lines "TYPE JSON" from FILE (TYPE as
// "hullpipe_msgs/msg/EyeViews", JSON the message's fields; a field left out is
// its zero value), prints one line per message: the bytes in hex, or
// "error: ...".
// Usage: node encode_ros2.mjs FILE
import { readFileSync } from "node:fs";
import { MessageWriter } from "@foxglove/rosmsg2-serialization";
import { definitionsOf } from "./ros2_definitions.mjs";

const writers = new Map();
for (const line of readFileSync(process.argv[2], "utf8").split("\n")) {
  if (!line.trim()) continue;
  const space = line.indexOf(" ");
  try {
    const name = line.slice(0, space).replace("/msg/", "/");
    if (!writers.has(name)) writers.set(name, new MessageWriter(definitionsOf(name)));
    const bytes = writers.get(name).writeMessage(JSON.parse(line.slice(space + 1)));
    process.stdout.write(Buffer.from(bytes).toString("hex") + "\n");
  } catch (e) {
    process.stdout.write("error: " + String(e && e.message ? e.message : e) + "\n");
  }
}
