// hullpipe_ros2's work (docs/ros2.md): hullpipe's cameras, object-pixel maps
// and images published as ROS 2 topics, and a ROS 2 tracker's PoseStamped
// turned into hullpipe's HeadPose, between two DDS participants (hullpipe's
// domain and the ROS 2 network's, which may be the same). The pipeline's
// nodes and topics are unchanged: it only reads them (best-effort, newest
// first, so no writer of the pipeline ever waits for it) and writes the head
// pose render_node already follows.
//
// ROS 2 topics (ROS names; "rt" + the name on the wire, ros2_topics.h):
//   /hullpipe/cam<id>/camera_info        sensor_msgs/CameraInfo, with each map
//   /hullpipe/cam<id>/object_pixel_map   sensor_msgs/Image mono8 (maps: on)
//   /hullpipe/cam<id>/image/compressed   sensor_msgs/CompressedImage (JPEG frames)
//   /hullpipe/cam<id>/image              sensor_msgs/Image bgr8 (raw frames)
//   /tf_static                           tf2_msgs/TFMessage, every camera's frame
//   options.head_pose_topic (read)       geometry_msgs/PoseStamped -> HeadPose
// Bounds: at most 64 cameras (a camera past them is refused, named once,
// counted); a pose that fails HeadFromPoseStamped is refused, named once per
// reason, counted.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <string>

#include "hullpipe/dds/dds.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/geometry/camera.h"
#include "hullpipe/pipeline/clock.h"
#include "hullpipe/ros2/ros2_messages.h"
#include "hullpipe/ros2/ros2_topics.h"

namespace hullpipe::ros2 {

struct Ros2BridgeOptions {
  bool maps = true;    ///< Publish the object-pixel maps (mono8).
  bool images = true;  ///< Publish the camera frames that arrive as JPEG.
  /// The ROS 2 topic of the tracker's PoseStamped ("" : none).
  std::string head_pose_topic = "/hullpipe/head_pose";
  /// HeadPose.tracker_id of the poses it passes on.
  uint32_t tracker_id = 20;
  /// What a pose must satisfy (frame, stamp skew, position bound); now_ns is
  /// the clock's at each pose.
  PoseCheck pose;
  /// Throws std::invalid_argument naming the option (a bad topic name).
  void Check() const;
};

/// What the bridge has done, for its NodeStats and its end line.
struct Ros2BridgeCounts {
  uint64_t camera_infos = 0, maps = 0, images = 0, tf_static = 0, poses = 0;
  uint64_t poses_refused = 0, cameras_refused = 0, samples_refused = 0;
};

class Ros2Bridge {
 public:
  static constexpr size_t kMaxCameras = 64;
  /// Reads on `hullpipe`, publishes on `ros` (the same participant when the
  /// domains are). Throws std::invalid_argument for bad options, DdsError.
  Ros2Bridge(const dds::Participant& hullpipe, const dds::Participant& ros, Ros2BridgeOptions options,
             const Clock& clock);
  /// Takes every sample that arrived and publishes what it gives; returns how
  /// many it took.
  size_t Step();
  /// The readers' conditions, for a waitset.
  std::vector<dds_entity_t> Conditions() const;
  const Ros2BridgeCounts& counts() const { return counts_; }

 private:
  struct CameraTopics {
    Camera camera;
    std::unique_ptr<dds::Writer<sensor_msgs_msg_dds__CameraInfo_>> info;
    std::unique_ptr<dds::Writer<sensor_msgs_msg_dds__Image_>> map;
    std::unique_ptr<dds::Writer<sensor_msgs_msg_dds__CompressedImage_>> jpeg;
    std::unique_ptr<dds::Writer<sensor_msgs_msg_dds__Image_>> raw;
  };
  void OnCameraInfo(const hullpipe_msg_CameraInfo& m);
  void OnMap(const hullpipe_msg_ObjectPixelMap& m);
  void OnImage(const hullpipe_msg_CameraImage& m);
  void OnPose(const geometry_msgs_msg_dds__PoseStamped_& m);
  void PublishTfStatic();
  void Refuse(uint64_t* counter, const std::string& kind, const std::string& why);

  const dds::Participant& ros_;
  Ros2BridgeOptions o_;
  const Clock& clock_;
  dds::Reader<hullpipe_msg_CameraInfo> infos_;
  dds::Reader<hullpipe_msg_ObjectPixelMap> maps_;
  dds::Reader<hullpipe_msg_CameraImage> images_;
  dds::Writer<tf2_msgs_msg_dds__TFMessage_> tf_static_;
  std::unique_ptr<dds::Reader<geometry_msgs_msg_dds__PoseStamped_>> poses_;
  std::unique_ptr<dds::Writer<hullpipe_msg_HeadPose>> head_;
  std::map<int, CameraTopics> cameras_;
  std::set<std::string> said_;  // reasons named once
  Ros2BridgeCounts counts_;
};

}  // namespace hullpipe::ros2
