// The ROS 2 message definitions the interoperability scripts judge hullpipe
// by, none of them hullpipe's IDL: the ROS 2 Humble definitions Foxglove ships
// (@foxglove/rosmsg-msgs-common's ros2humble), and hullpipe's own
// hullpipe_msgs types read from the ament package's .msg files
// (ros2/hullpipe_msgs/msg, what a ROS 2 machine builds) by Foxglove's .msg
// parser (@foxglove/rosmsg).
import { readdirSync, readFileSync } from "node:fs";
import { dirname, join } from "node:path";
import { fileURLToPath } from "node:url";
import { parse } from "@foxglove/rosmsg";
import { ros2humble } from "@foxglove/rosmsg-msgs-common";

const hullpipeMsgs = join(dirname(fileURLToPath(import.meta.url)), "../../ros2/hullpipe_msgs/msg");

// hullpipe_msgs/Type's root definition from its .msg file (complex fields left
// named, resolved by name against the others).
function hullpipeDefinition(name) {
  const text = readFileSync(join(hullpipeMsgs, name.split("/")[1] + ".msg"), "utf8");
  const [root] = parse(text, { ros2: true, skipTypeFixup: true });
  return root;
}

const hullpipeNames = readdirSync(hullpipeMsgs)
  .filter((f) => f.endsWith(".msg"))
  .map((f) => "hullpipe_msgs/" + f.slice(0, -4));

// The definition of `name` ("sensor_msgs/CameraInfo", "hullpipe_msgs/EyeViews")
// first, then every definition it may reference (Foxglove's reader and writer
// resolve complex fields by name).
export function definitionsOf(name) {
  const root = name.startsWith("hullpipe_msgs/") ? hullpipeDefinition(name) : ros2humble[name];
  if (!root) throw new Error(`no ROS 2 Humble definition of ${name}`);
  const rest = Object.entries(ros2humble)
    .filter(([key]) => key !== name)
    .map(([key, def]) => ({ ...def, name: key }));
  const own = hullpipeNames.filter((key) => key !== name).map((key) => ({ ...hullpipeDefinition(key), name: key }));
  return [{ ...root, name: undefined }, ...rest, ...own];
}
