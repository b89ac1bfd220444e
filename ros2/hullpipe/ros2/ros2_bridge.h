// hullpipe_ros2's work (docs/ros2.md): hullpipe's samples published as ROS 2
// topics (what Ros2Deriver gives: cameras, maps, frames, /tf_static, the view
// and its pose on /tf, the hull's points, the virtual objects and CAD model
// parts as markers, the collision reports), and
// a ROS 2 tracker's PoseStamped turned into hullpipe's HeadPose (and a
// headset client's hullpipe_msgs/EyeViews into hullpipe's EyeViews), between two
// DDS participants (hullpipe's domain and the ROS 2 network's, which may be
// the same). The pipeline's nodes and topics are unchanged: it only reads
// them (best-effort, newest first, so no writer of the pipeline ever waits for
// it) and writes the head pose or eye views render_node follows. A pose that
// fails HeadFromPoseStamped, eye views that fail EyeViewsFromRos2, a sample that does not convert and a camera past
// Ros2Deriver::kMaxCameras are refused, named once per kind, counted.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <type_traits>
#include <vector>

#include "hullpipe/dds/dds.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/pipeline/clock.h"
#include "hullpipe/ros2/ros2_deriver.h"
#include "hullpipe/ros2/ros2_messages.h"
#include "hullpipe/ros2/ros2_topics.h"

namespace hullpipe::ros2 {

struct Ros2BridgeOptions {
  Ros2DeriverOptions derive;  ///< What is published.
  /// The ROS 2 topic of the tracker's PoseStamped ("" : none).
  std::string head_pose_topic = "/hullpipe/head_pose";
  /// A tf frame as the head pose ("" : none): /tf's transforms from
  /// pose.frame_id to this frame (a tracker's broadcaster), at most
  /// kMaxTransformsPerMessage looked at per message.
  std::string head_frame;
  /// The ROS 2 topic of a headset client's hullpipe_msgs/EyeViews (both eyes'
  /// XrPosef and XrFovf from one xrLocateViews), passed on as hullpipe's
  /// EyeViews for render_node --view eyes-topic ("" : none).
  std::string eye_views_topic = "/hullpipe/eye_views";
  /// HeadPose.tracker_id (and EyeViews.tracker_id) of what it passes on.
  uint32_t tracker_id = 20;
  /// Tracked cameras (paper §5: the camera on the head-mounted display), by
  /// hullpipe camera id: a ROS 2 PoseStamped topic, or a tf frame (a child of
  /// pose.frame_id on /tf), whose poses are the camera's optical frame in the
  /// world (world_from_camera, REP 103's optical convention = hullpipe's), passed
  /// on as CameraPose for capture_node (rig 'tracked: topic'). At most
  /// kMaxTrackedCameras in all.
  std::map<uint32_t, std::string> camera_pose_topics, camera_frames;
  static constexpr size_t kMaxTrackedCameras = 64;
  /// The ROS node its ROS 2 readers and writers belong to, published on
  /// `ros_discovery_info` (rmw_dds_common's ParticipantEntitiesInfo, as every
  /// rmw does) so `ros2 node list` names it; "": not published (ROS 2 tools
  /// then list the topics under a placeholder node). [A-Za-z_][A-Za-z0-9_]*,
  /// at most 256 characters; the namespace is "/".
  std::string node_name = "hullpipe_ros2";
  /// What a pose must satisfy (frame, stamp skew, position bound); now_ns is
  /// the clock's at each pose.
  PoseCheck pose;
  /// Throws std::invalid_argument naming the option (a bad topic name).
  void Check() const;
};

/// What the bridge has done, for its NodeStats and its end line.
struct Ros2BridgeCounts {
  std::map<std::string, uint64_t> published;  ///< Per ROS 2 topic.
  uint64_t poses = 0, poses_refused = 0, samples_refused = 0;
  uint64_t camera_poses = 0;  ///< Tracked cameras' poses passed on (refused ones are in poses_refused).
  uint64_t eye_views = 0;     ///< Headset eye views passed on (refused ones are in poses_refused).
  uint64_t transforms_skipped = 0;  ///< /tf transforms past kMaxTransformsPerMessage in a message.
};

class Ros2Bridge {
 public:
  /// Reads on `hullpipe`, publishes on `ros` (the same participant when the
  /// domains are). Throws std::invalid_argument for bad options, DdsError.
  Ros2Bridge(const dds::Participant& hullpipe, const dds::Participant& ros, Ros2BridgeOptions options,
             const Clock& clock);
  /// Takes every sample that arrived and publishes what it gives; returns how
  /// many it took.
  size_t Step();
  /// The conditions of the readers on `hullpipe`, for a waitset there.
  std::vector<dds_entity_t> HullpipeConditions() const;
  /// The trackers' readers' conditions (on `ros`): the head pose and eye views
  /// topics, /tf, the tracked cameras' topics.
  std::vector<dds_entity_t> TrackerConditions() const;
  const Ros2BridgeCounts& counts() const { return counts_; }

 private:
  struct Publication {
    dds::Entity topic, writer;
  };
  void Publish(const Ros2Message& m);
  // ros_discovery_info: this participant's node with its ROS 2 readers and
  // writers (their GUIDs as gids), sent again whenever one is added.
  void PublishDiscovery();
  void OnPose(const geometry_msgs_msg_dds__PoseStamped_& m);
  void OnTf(const tf2_msgs_msg_dds__TFMessage_& m);
  void OnEyeViews(const hullpipe_msgs_msg_dds__EyeViews_& m);
  // Checks a tracker's pose or views (`convert` throws MessageError) and
  // returns them, or refuses them once per kind (`what` names whose), counted.
  template <typename Convert>
  auto Checked(const Convert& convert, const std::string& what)
      -> std::optional<std::invoke_result_t<const Convert&, const PoseCheck&>>;
  void PassOnHead(const Rigid3d& world_from_eye, const builtin_interfaces_msg_dds__Time_& stamp);
  void PassOnCamera(uint32_t camera_id, const Rigid3d& world_from_camera,
                    const builtin_interfaces_msg_dds__Time_& stamp);
  void Refused(uint64_t* counter, const std::string& kind, const std::string& why);

  const dds::Participant& ros_;
  Ros2BridgeOptions o_;
  const Clock& clock_;
  Ros2Deriver deriver_;
  dds::Reader<hullpipe_msg_CameraInfo> infos_;
  dds::Reader<hullpipe_msg_ObjectPixelMap> maps_;
  dds::Reader<hullpipe_msg_CameraImage> images_;
  dds::Reader<hullpipe_msg_ViewPose> views_;
  dds::Reader<hullpipe_msg_HullView> tiles_;
  dds::Reader<hullpipe_msg_CompositedView> composited_;
  dds::Reader<hullpipe_msg_VirtualObjectState> objects_;
  dds::Reader<hullpipe_msg_CollisionReport> reports_;
  dds::Reader<hullpipe_msg_VirtualMesh> meshes_;
  dds::Reader<hullpipe_msg_ModelPart> model_parts_;
  dds::Reader<hullpipe_msg_ModelState> model_states_;
  std::unique_ptr<dds::Reader<geometry_msgs_msg_dds__PoseStamped_>> poses_;
  std::unique_ptr<dds::Reader<tf2_msgs_msg_dds__TFMessage_>> tf_;
  std::unique_ptr<dds::Writer<hullpipe_msg_HeadPose>> head_;
  std::unique_ptr<dds::Reader<hullpipe_msgs_msg_dds__EyeViews_>> eye_views_in_;
  std::unique_ptr<dds::Writer<hullpipe_msg_EyeViews>> eye_views_;
  struct CameraTopic {
    uint32_t camera_id;
    std::unique_ptr<dds::Reader<geometry_msgs_msg_dds__PoseStamped_>> reader;
  };
  std::vector<CameraTopic> camera_topics_;
  std::unique_ptr<dds::Writer<hullpipe_msg_CameraPose>> camera_poses_;
  std::map<std::string, Publication> publications_;  // by ROS 2 topic (bounded by the deriver's topics)
  std::unique_ptr<dds::Writer<rmw_dds_common_msg_dds__ParticipantEntitiesInfo_>> discovery_;
  bool discovery_stale_ = true;
  std::set<std::string> said_;                       // kinds of refusal named once
  Ros2BridgeCounts counts_;
};

}  // namespace hullpipe::ros2
