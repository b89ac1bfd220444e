// hullpipe_ros2: hullpipe on a lab's ROS 2 network (docs/ros2.md), beside the
// pipeline as hullpipe_bridge is: its cameras, object-pixel maps and frames as
// ROS 2 topics (sensor_msgs, tf2_msgs), the view, the hull's points, the
// virtual objects and model parts as markers, the collision reports; and a ROS 2
// tracker's PoseStamped as render_node's head pose, a headset client's
// hullpipe_msgs/EyeViews as its eye views, over plain Cyclone DDS
// (rmw_cyclonedds' wire form: nothing from ROS installed).
//   hullpipe_ros2 --domain 7 [--ros-domain 0] [--no-maps] [--no-images]
//                 [--head-pose-topic /hullpipe/head_pose] [--head-frame FRAME]
//                 [--eye-views-topic /hullpipe/eye_views]
//                 [--pose-frame hullpipe_world]
// Then on a ROS 2 machine (ROS_DOMAIN_ID = --ros-domain, rmw_cyclonedds or any
// DDS rmw): ros2 topic list; rviz2 with the fixed frame hullpipe_world.
// Stops within a second of SIGINT.
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/dds/node.h"
#include "hullpipe/pipeline/clock.h"
#include "hullpipe/pipeline/node_counters.h"
#include "hullpipe/ros2/ros2_bridge.h"
#include "hullpipe/util/cli_range.h"

using namespace hullpipe;
using namespace hullpipe::dds;

int main(int argc, char** argv) {
  CLI::App app{"hullpipe_ros2: hullpipe's cameras and maps as ROS 2 topics, a ROS 2 tracker as the head pose"};
  CommonOptions common;
  OpenCommandLine(argc, argv, "hullpipe_ros2", app, common, /*with_run_id=*/true);
  int ros_domain = -1;
  ros2::Ros2BridgeOptions o;
  bool no_maps = false, no_images = false, no_view = false, no_hull = false, no_markers = false,
       no_collisions = false;
  app.add_option("--ros-domain", ros_domain, "The ROS 2 network's domain (ROS_DOMAIN_ID; default: --domain)")
      ->check(DomainIdRange());
  app.add_flag("--no-maps", no_maps, "Do not publish the object-pixel maps");
  app.add_flag("--no-images", no_images, "Do not publish the camera frames");
  app.add_flag("--no-view", no_view, "Do not publish the composited view and its pose on /tf");
  app.add_flag("--no-hull-points", no_hull, "Do not publish the hull's points (PointCloud2)");
  app.add_flag("--no-markers", no_markers,
               "Do not publish the virtual objects, meshes, model parts and contacts as markers");
  app.add_flag("--no-collisions", no_collisions,
               "Do not publish the collision reports (hullpipe_msgs/CollisionReport)");
  app.add_option("--model-marker-period", o.derive.model_marker_period_s,
                 "Least seconds between two /hullpipe/model_markers (every part's geometry, sent again when a "
                 "part's contact state changes)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 60.0));
  app.add_option("--hull-point-stride", o.derive.hull_point_stride, "Every this many view pixels, each way")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  app.add_option("--head-pose-topic", o.head_pose_topic,
                 "ROS 2 topic of the tracker's geometry_msgs/PoseStamped (\"\": none)")
      ->capture_default_str();
  app.add_option("--eye-views-topic", o.eye_views_topic,
                 "ROS 2 topic of a headset client's hullpipe_msgs/EyeViews (each eye's XrPosef and XrFovf), passed "
                 "on for render_node --view eyes-topic (\"\": none)")
      ->capture_default_str();
  app.add_option("--head-frame", o.head_frame,
                 "A tf frame as the head pose: /tf's transforms from --pose-frame to this frame (\"\": none)");
  app.add_option("--pose-frame", o.pose.frame_id, "The frame a tracker's pose must be in")->capture_default_str();
  app.add_option("--max-pose-skew", o.pose.max_skew_s, "Most seconds between a pose's stamp and now")
      ->capture_default_str()
      ->check(CLI::Range(0.001, 86400.0));
  app.add_option("--ros-node-name", o.node_name,
                 "The ROS node named on ros_discovery_info for ros2 node list (\"\": none)")
      ->capture_default_str();
  app.add_option("--tracker-id", o.tracker_id, "HeadPose.tracker_id (and EyeViews') of the poses passed on")
      ->capture_default_str();
  std::vector<std::string> camera_pose_specs, camera_frame_specs;
  app.add_option("--camera-pose", camera_pose_specs,
                 "ID=TOPIC: a ROS 2 PoseStamped topic as tracked camera ID's pose (its optical frame in "
                 "--pose-frame), passed on to capture_node (rig 'tracked: topic'); repeatable");
  app.add_option("--camera-frame", camera_frame_specs,
                 "ID=FRAME: a tf frame (a child of --pose-frame on /tf) as tracked camera ID's pose; repeatable");
  CLI11_PARSE(app, argc, argv);
  o.derive.maps = !no_maps;
  o.derive.images = !no_images;
  o.derive.view = !no_view;
  o.derive.hull_points = !no_hull;
  o.derive.markers = !no_markers;
  o.derive.collisions = !no_collisions;
  try {
    // ID=VALUE, ID a camera id in [1, 1e6].
    auto camera_specs = [](const std::vector<std::string>& specs, const char* flag) {
      std::map<uint32_t, std::string> out;
      for (const std::string& s : specs) {
        const size_t eq = s.find('=');
        char* end = nullptr;
        const long id = eq == std::string::npos ? 0 : std::strtol(s.c_str(), &end, 10);
        if (eq == std::string::npos || end != s.c_str() + eq || id < 1 || id > 1000000 || eq + 1 == s.size())
          throw std::invalid_argument(std::string(flag) + " '" + s + "': give ID=VALUE, ID a camera id");
        if (!out.emplace(uint32_t(id), s.substr(eq + 1)).second)
          throw std::invalid_argument(std::string(flag) + ": camera " + std::to_string(id) + " given twice");
      }
      return out;
    };
    o.camera_pose_topics = camera_specs(camera_pose_specs, "--camera-pose");
    o.camera_frames = camera_specs(camera_frame_specs, "--camera-frame");
    o.Check();
    auto participant = StartNode("ros2", common);
    std::unique_ptr<Participant> ros_participant;
    if (ros_domain >= 0 && uint32_t(ros_domain) != common.domain)
      ros_participant = std::make_unique<Participant>(uint32_t(ros_domain));
    const Participant& ros = ros_participant ? *ros_participant : *participant;
    SystemClock clock;
    NodeCounters counters(clock);
    NodeReporter reporter(*participant, "ros2", counters);
    ros2::Ros2Bridge bridge(*participant, ros, o, clock);
    WaitSet ws(*participant);
    for (dds_entity_t c : bridge.HullpipeConditions()) ws.AttachCondition(c);
    // The tracker's reader lives on the ROS 2 participant: on the same one it
    // wakes the waitset; on another (a waitset is one participant's) it is
    // polled every 20 ms.
    const auto tracker = bridge.TrackerConditions();
    if (!ros_participant)
      for (dds_entity_t c : tracker) ws.AttachCondition(c);
    const double wait_s = ros_participant && !tracker.empty() ? 0.02 : 0.2;
    spdlog::info("publishing hullpipe's topics on ROS 2 domain {}{}{}",
                 ros_participant ? ros_domain : int(common.domain),
                 o.head_pose_topic.empty() ? "" : "; following " + o.head_pose_topic,
                 o.eye_views_topic.empty() ? "" : " and " + o.eye_views_topic);
    while (!StopRequested()) {
      ws.Wait(wait_s);
      counters.FrameIn(bridge.Step());
      const auto& c = bridge.counts();
      counters.SetRejected(c.poses_refused + c.samples_refused + c.transforms_skipped);
    }
    const auto& c = bridge.counts();
    std::string topics;
    for (const auto& [topic, n] : c.published) topics += fmt::format("{}{} {}", topics.empty() ? "" : ", ", topic, n);
    spdlog::info("published {}; {} head poses, {} eye views and {} camera poses passed on, {} refused; {} samples "
                 "refused; {} tf transforms past the bound",
                 topics.empty() ? "nothing" : topics, c.poses, c.eye_views, c.camera_poses, c.poses_refused,
                 c.samples_refused, c.transforms_skipped);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
