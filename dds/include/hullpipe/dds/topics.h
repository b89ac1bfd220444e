// hullpipe's topics: name, type and QoS of each (see idl/hullpipe.idl).
#pragma once

#include "hullpipe.h"  // idlc-generated
#include "hullpipe/dds/dds.h"

namespace hullpipe::dds {

// Instances a reader keeps (QosSpec::max_instances) of a best-effort topic,
// keyed by a tracker or camera id: more than a lab has, so a peer publishing
// under ever new ids cannot grow a node's reader without end
// (docs/reliability.md). Reliable topics are not bounded: past its bound a
// Cyclone reader of a reliable topic stalls the receive path.
constexpr int32_t kCameraInstances = 4 * 64;  // camera_id: 4 x Rig::kMaxCameras (checked in convert.cc)
constexpr int32_t kTrackerInstances = 64;     // tracker_id: a lab's trackers
constexpr int32_t kUnbounded = 0;

#define HULLPIPE_TOPIC(Type, name, reliable, transient_local, depth, instances)        \
  template <>                                                                          \
  struct TopicTraits<hullpipe_msg_##Type> {                                            \
    static const dds_topic_descriptor_t* Descriptor() { return &hullpipe_msg_##Type##_desc; } \
    static constexpr const char* kName = name;                                         \
    static constexpr QosSpec kQos{reliable, transient_local, depth, instances};        \
  };

HULLPIPE_TOPIC(CameraInfo, "hullpipe/camera_info", true, true, 1, kUnbounded)
HULLPIPE_TOPIC(ObjectPixelMap, "hullpipe/object_pixel_map", true, false, 4, kUnbounded)
HULLPIPE_TOPIC(CameraImage, "hullpipe/camera_image", true, false, 4, kUnbounded)
HULLPIPE_TOPIC(ViewPose, "hullpipe/view_pose", true, false, 4, kUnbounded)
HULLPIPE_TOPIC(HullView, "hullpipe/hull_view", true, false, 4, kUnbounded)
// For viewers: best-effort, so a reader that lags never makes render_node wait.
HULLPIPE_TOPIC(CompositedView, "hullpipe/composited_view", false, false, 1, kUnbounded)
HULLPIPE_TOPIC(VirtualObjectState, "hullpipe/object_state", true, false, 1, kUnbounded)
HULLPIPE_TOPIC(CollisionReport, "hullpipe/collision_report", true, false, 16, kUnbounded)
HULLPIPE_TOPIC(NodeStats, "hullpipe/node_stats", true, true, 1, kUnbounded)
HULLPIPE_TOPIC(VirtualMesh, "hullpipe/virtual_mesh", true, false, 1, kUnbounded)
// A model's geometry is sent once: transient-local, the last per part kept.
HULLPIPE_TOPIC(ModelPart, "hullpipe/model_part", true, true, 1, kUnbounded)
HULLPIPE_TOPIC(ModelState, "hullpipe/model_state", true, false, 2, kUnbounded)
// Commands are transient-local: a sim_node whose reader matches the commander a
// moment after the commander matched it still gets the command (hullpipe_cmd then
// waits for its acknowledgement before it leaves).
HULLPIPE_TOPIC(SceneCommand, "hullpipe/scene_command", true, true, 8, kUnbounded)
HULLPIPE_TOPIC(HeadPose, "hullpipe/head_pose", false, false, 1, kTrackerInstances)
HULLPIPE_TOPIC(EyeViews, "hullpipe/eye_views", false, false, 1, kTrackerInstances)
// A tracker's camera poses: best-effort, and deep enough that capture_node,
// which takes them once a frame, keeps the samples around each frame's time.
HULLPIPE_TOPIC(CameraPose, "hullpipe/camera_pose", false, false, 64, kCameraInstances)
HULLPIPE_TOPIC(CaptureTimeline, "hullpipe/capture_timeline", true, true, 1, kUnbounded)
HULLPIPE_TOPIC(RecordCommand, "hullpipe/record_command", true, false, 8, kUnbounded)

#undef HULLPIPE_TOPIC

}  // namespace hullpipe::dds
