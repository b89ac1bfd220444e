// What rosbag2 writes beside a ROS 2 message in MCAP (docs/ros2.md, "Bags"):
// each type's schema as `ros2msg` text (its .msg definition, then every type
// it uses, each after a line of 80 '=' and "MSG: pkg/Type", as rosbag2's
// MCAP storage plugin concatenates them), and each channel's
// `offered_qos_profiles` (the YAML rosbag2 writes, so `ros2 bag play` offers the
// same QoS). The definitions are ROS 2 Humble's, the fields of idl/ros2.idl,
// and hullpipe's own hullpipe_msgs (ros2/hullpipe_msgs/msg, compiled in).
#pragma once

#include <string>
#include <vector>

#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/dds.h"

namespace hullpipe::ros2 {

/// The ROS 2 type names this build writes ("sensor_msgs/msg/CameraInfo", ...).
const std::vector<std::string>& Ros2TypeNames();

/// The `ros2msg` schema of `type` ("sensor_msgs/msg/CameraInfo"), with every
/// type it uses. Throws std::invalid_argument for a type not in Ros2TypeNames().
std::string Ros2MsgSchema(const std::string& type);

/// rosbag2's `offered_qos_profiles` YAML for one writer of `qos` (history keep
/// last, its depth; reliability 1 reliable / 2 best effort; durability 1
/// transient local / 2 volatile; deadline, lifespan and lease infinite).
std::string OfferedQosProfiles(const dds::QosSpec& qos);

/// The type as hullpipe's serializer (dds::CdrWriter) knows a type: its
/// descriptor ("sensor_msgs::msg::dds_::CameraInfo_"), a topic of its own for
/// the sertype probe, rclcpp's default QoS. Throws std::invalid_argument for a
/// type neither in Ros2TypeNames() nor "hullpipe_msgs/msg/EyeViews" (which
/// hullpipe_ros2 reads and never writes).
dds::KnownType Ros2KnownType(const std::string& type);

}  // namespace hullpipe::ros2
