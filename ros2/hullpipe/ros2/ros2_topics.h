// ROS 2 topics on plain Cyclone DDS (docs/ros2.md), as rmw_cyclonedds names
// them: the DDS topic of ROS name "/a/b" is "rt/a/b"; the types of
// idl/ros2.idl; QoS as rclcpp's defaults (reliable, volatile, keep-last 10) and
// /tf_static's (transient-local, keep-last 1, as tf2_ros's static broadcaster).
#pragma once

#include <string>

#include "hullpipe/dds/dds.h"
#include "ros2.h"  // idlc-generated from idl/ros2.idl

namespace hullpipe::dds {

// The ROS 2 types: descriptors only (each is published on many topics: the
// topic name and QoS are given where a reader or writer is made).
#define HULLPIPE_ROS2_TYPE(C)                                                       \
  template <>                                                                       \
  struct TopicTraits<C> {                                                           \
    static const dds_topic_descriptor_t* Descriptor() { return &C##_desc; }         \
    static constexpr const char* kName = "";                                        \
    static constexpr QosSpec kQos{true, false, 10};                                 \
  };
HULLPIPE_ROS2_TYPE(sensor_msgs_msg_dds__CameraInfo_)
HULLPIPE_ROS2_TYPE(sensor_msgs_msg_dds__Image_)
HULLPIPE_ROS2_TYPE(sensor_msgs_msg_dds__CompressedImage_)
HULLPIPE_ROS2_TYPE(tf2_msgs_msg_dds__TFMessage_)
HULLPIPE_ROS2_TYPE(geometry_msgs_msg_dds__TransformStamped_)
HULLPIPE_ROS2_TYPE(geometry_msgs_msg_dds__PoseStamped_)
HULLPIPE_ROS2_TYPE(sensor_msgs_msg_dds__PointCloud2_)
HULLPIPE_ROS2_TYPE(visualization_msgs_msg_dds__MarkerArray_)
HULLPIPE_ROS2_TYPE(hullpipe_msgs_msg_dds__CollisionReport_)
HULLPIPE_ROS2_TYPE(hullpipe_msgs_msg_dds__EyeViews_)
HULLPIPE_ROS2_TYPE(rmw_dds_common_msg_dds__ParticipantEntitiesInfo_)
#undef HULLPIPE_ROS2_TYPE

}  // namespace hullpipe::dds

namespace hullpipe::ros2 {

/// rclcpp's default QoS: reliable, volatile, keep-last 10.
inline constexpr dds::QosSpec kDefaultQos{true, false, 10};
/// /tf_static's: reliable, transient-local, keep-last 1 (the last message holds
/// every static transform).
inline constexpr dds::QosSpec kTfStaticQos{true, true, 1};
/// A latched topic's (/hullpipe/model_markers): reliable, transient-local,
/// keep-last 1 (the last message holds every part; a late RViz gets it).
inline constexpr dds::QosSpec kLatchedQos{true, true, 1};
/// A tracker's poses are read best-effort, the newest only: a best-effort
/// reader matches reliable and best-effort (sensor-data) writers alike.
inline constexpr dds::QosSpec kPoseReaderQos{false, false, 1};
/// ros_discovery_info's, as rmw_dds_common's graph cache writes it: reliable,
/// transient-local, keep-last 1.
inline constexpr dds::QosSpec kDiscoveryQos{true, true, 1};
/// A tracked camera's poses: best-effort, deep enough to keep a 1 kHz
/// tracker's samples between two takes (capture_node interpolates them).
inline constexpr dds::QosSpec kCameraPoseReaderQos{false, false, 64};
/// /tf read best-effort, a few messages deep (a tracker's frame among others').
inline constexpr dds::QosSpec kTfReaderQos{false, false, 16};

/// The DDS topic of a ROS 2 topic name: "rt" + the name ("/tf" -> "rt/tf").
/// Throws std::invalid_argument unless the name is absolute ("/...") and only
/// [A-Za-z0-9_/] with no empty, trailing or digit-led token (ROS 2's rules).
std::string DdsTopicOf(const std::string& ros_name);

}  // namespace hullpipe::ros2
