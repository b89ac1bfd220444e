// hullpipe's samples as ROS 2 messages (docs/ros2.md): the ROS 2 Humble types of
// idl/ros2.idl (sensor_msgs, geometry_msgs, tf2_msgs, std_msgs), made from
// hullpipe's cameras, maps and images, and a ROS 2 tracker's pose (or a
// headset client's eye views) read back as hullpipe's head pose (eye views). ROS 2's conventions, stated once here:
//   - time: builtin_interfaces/Time of hullpipe's capture time, nanoseconds
//     split into sec and nanosec (sec may be negative; nanosec in [0, 1e9));
//   - frames: a camera's optical frame is "hullpipe_cam<id>" (REP 103's
//     optical convention: x right, y down, z forward, which is hullpipe's and
//     OpenCV's camera frame); the rig's world frame is "hullpipe_world";
//   - pixels: ROS's (and OpenCV's) pixel centres are at integers, hullpipe's
//     at +0.5 (geometry/conventions.h): cx and cy move by 0.5 on the way out;
//   - CameraInfo: K = [fx skew cx; 0 fy cy; 0 0 1] (ROS pixels), D plumb_bob
//     (k1 k2 p1 p2 k3, OpenCV's), R the identity (one camera, no rectification
//     pair), P = [K | 0] (the rectified image taken at the camera's own
//     intrinsics: image_proc's undistortion keeps K);
//   - tf: each camera's transform is parent "hullpipe_world" -> child
//     "hullpipe_cam<id>", translation the camera centre and rotation R^T of
//     x_cam = R x_world + t (world_from_cam, as tf2 composes).
// Errors: MessageError (dds/owned_sample.h) naming the field.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/dds/owned_sample.h"
#include "hullpipe/geometry/camera.h"
#include "hullpipe/geometry/rigid3.h"
#include "hullpipe/pipeline/messages.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/stereo_views.h"
#include "ros2.h"  // idlc-generated from idl/ros2.idl

namespace hullpipe::ros2 {

/// A ROS 2 message with the storage its sequences and strings point into (as
/// dds::OwnedSample): valid while it lives; move-only.
template <typename Msg>
struct RosSample {
  Msg msg{};
  std::vector<double> doubles;
  std::vector<uint8_t> bytes;
  std::vector<std::string> strings;  ///< Reserved before use: their c_str() stay put.
  std::vector<geometry_msgs_msg_dds__TransformStamped_> transforms;
  std::vector<sensor_msgs_msg_dds__PointField_> fields;
  std::vector<geometry_msgs_msg_dds__Point_> points;
  std::vector<std_msgs_msg_dds__ColorRGBA_> colors;
  std::vector<visualization_msgs_msg_dds__Marker_> markers;
  std::vector<uint32_t> uints;
  RosSample() = default;
  RosSample(const RosSample&) = delete;
  RosSample& operator=(const RosSample&) = delete;
  RosSample(RosSample&&) = default;
  RosSample& operator=(RosSample&&) = default;
};

/// The rig's world frame id.
inline constexpr const char* kWorldFrame = "hullpipe_world";
/// render_node's view (the head pose it composites for; OpenCV eye frame).
inline constexpr const char* kViewFrame = "hullpipe_view";
/// The frame of a view of `eye`: kViewFrame for the one view (kMono),
/// "hullpipe_view_left" and "hullpipe_view_right" for a headset's eyes
/// (render_node --stereo; docs/hmd.md).
std::string ViewFrameId(ViewEye eye);
/// The ROS 2 topic of render_node's composited view of `eye`:
/// "/hullpipe/view/compressed" (kMono), "/hullpipe/view/left/compressed",
/// "/hullpipe/view/right/compressed" (image_transport's compressed topic of a
/// stereo pair's left and right image).
std::string ViewImageTopic(ViewEye eye);
/// Camera `id`'s optical frame id: "hullpipe_cam<id>".
std::string CameraFrameId(int id);

/// builtin_interfaces/Time of `ns` nanoseconds (sec = floor(ns / 1e9)).
builtin_interfaces_msg_dds__Time_ RosTime(int64_t ns);
/// Nanoseconds of a ROS 2 time. Throws MessageError if nanosec >= 1e9.
int64_t NanosecondsOf(const builtin_interfaces_msg_dds__Time_& t);

/// sensor_msgs/CameraInfo of `camera` (conventions above), stamped `stamp_ns`,
/// frame CameraFrameId(camera.id).
RosSample<sensor_msgs_msg_dds__CameraInfo_> MakeCameraInfo(const Camera& camera, int64_t stamp_ns);

/// sensor_msgs/Image, encoding mono8, of an object-pixel map (CV_8UC1: 255
/// object, 0 background). Throws MessageError for another type or an empty map.
RosSample<sensor_msgs_msg_dds__Image_> MakeMono8Image(const cv::Mat& map, int64_t stamp_ns,
                                                      const std::string& frame_id);

/// sensor_msgs/Image, encoding bgr8, of a camera frame (CV_8UC3, B G R as
/// hullpipe's raw CameraImage). Throws MessageError for another type or an
/// empty image.
RosSample<sensor_msgs_msg_dds__Image_> MakeBgr8Image(const cv::Mat& bgr, int64_t stamp_ns, const std::string& frame_id);

/// sensor_msgs/CompressedImage of a JPEG file's bytes (format "jpeg"), passed
/// on as they are. Throws MessageError if `jpeg` is empty.
RosSample<sensor_msgs_msg_dds__CompressedImage_> MakeCompressedImage(std::vector<uint8_t> jpeg, int64_t stamp_ns,
                                                                     const std::string& frame_id);

/// tf2_msgs/TFMessage with one transform per camera, kWorldFrame ->
/// CameraFrameId(id) (for /tf_static: every camera in one message, as
/// tf2_ros's static broadcaster sends them).
RosSample<tf2_msgs_msg_dds__TFMessage_> MakeCameraTransforms(const std::vector<Camera>& cameras, int64_t stamp_ns);

/// geometry_msgs/PoseStamped of world_from_eye (the head pose a tracker sends),
/// in frame `frame_id`.
RosSample<geometry_msgs_msg_dds__PoseStamped_> MakePoseStamped(const Rigid3d& world_from_eye, int64_t stamp_ns,
                                                               const std::string& frame_id);

/// tf2_msgs/TFMessage with the view's pose: kWorldFrame -> ViewFrameId(eye)
/// (for /tf).
RosSample<tf2_msgs_msg_dds__TFMessage_> MakeViewTransform(const Rigid3d& world_from_eye, int64_t stamp_ns,
                                                          ViewEye eye = ViewEye::kMono);

/// sensor_msgs/PointCloud2 of the visual hull as the view sees it: every
/// `stride`-th pixel's hull point (depth: CV_32FC1 eye z, colour: CV_8UC3 BGR,
/// the view's size), in kWorldFrame, fields x y z (float32) and rgb (float32
/// holding 0x00RRGGBB, as PCL and RViz pack it), little-endian, dense, one row.
RosSample<sensor_msgs_msg_dds__PointCloud2_> MakeHullPointCloud(const NovelView& view, const cv::Mat& depth,
                                                                const cv::Mat& colour, int stride, int64_t stamp_ns);

/// visualization_msgs/MarkerArray (namespace "hullpipe_objects", id the object
/// id) of one virtual object's state: a SPHERE (scale its diameter) or a CUBE
/// (its size, at its orientation), red while it collides.
RosSample<visualization_msgs_msg_dds__MarkerArray_> MakeObjectMarker(const VirtualObjectSample& state,
                                                                     int64_t stamp_ns);
/// The same of a mesh (namespace "hullpipe_meshes"): a TRIANGLE_LIST, each
/// triangle's vertices in turn, coloured per vertex (red on a colliding
/// triangle); a point set (no triangles): a SPHERE_LIST of its point radius.
RosSample<visualization_msgs_msg_dds__MarkerArray_> MakeMeshMarker(const VirtualMeshSample& mesh, int64_t stamp_ns);
/// The same of a collision's points (namespace "hullpipe_contacts", id the
/// object id): a SPHERE_LIST of 1-cm red spheres (none: an empty list, which
/// clears the last).
RosSample<visualization_msgs_msg_dds__MarkerArray_> MakeContactMarker(uint32_t object_id,
                                                                      const std::vector<Eigen::Vector3d>& points,
                                                                      int64_t stamp_ns);

/// A CAD model part's body frame (ModelPart): "hullpipe_part<object_id>".
std::string PartFrameId(uint32_t object_id);

/// tf2_msgs/TFMessage with each part's pose after a step: kWorldFrame ->
/// PartFrameId(model_id + i) of world_from_body, for the parts i whose
/// `known[i]` is true (every part when `known` is empty), stamped with the
/// frameset's capture time (for /tf).
RosSample<tf2_msgs_msg_dds__TFMessage_> MakePartTransforms(const ModelStateSample& state,
                                                           const std::vector<bool>& known = {});

/// One model part's drawing for MakeModelMarkers: its geometry (body frame)
/// and its contact state (PartContact).
struct PartDrawing {
  const ModelPartSample* part = nullptr;
  uint8_t contact = kPartClear;
};

/// visualization_msgs/MarkerArray of CAD model parts (namespace
/// "hullpipe_models", id the part's object id): per part one TRIANGLE_LIST in
/// its own frame PartFrameId (frame_locked: it moves with the part's /tf), each
/// triangle's vertices in turn, in the material's colour, amber when near the
/// hull and red while colliding (docs/models.md's contact states).
RosSample<visualization_msgs_msg_dds__MarkerArray_> MakeModelMarkers(const std::vector<PartDrawing>& parts,
                                                                     int64_t stamp_ns);

/// hullpipe_msgs/CollisionReport (ros2/hullpipe_msgs/msg/CollisionReport.msg)
/// of one object's collision with the hull: the same fields as hullpipe's
/// CollisionReport, in kWorldFrame, stamped with the frameset's capture time.
RosSample<hullpipe_msgs_msg_dds__CollisionReport_> MakeCollisionReport(const CollisionReportSample& report);

/// What a tracker's pose must satisfy to drive the view.
struct PoseCheck {
  std::string frame_id = kWorldFrame;  ///< The only frame accepted (no tf lookup).
  int64_t now_ns = 0;                  ///< The reader's clock, nanoseconds.
  double max_skew_s = 60;              ///< |stamp - now| at most this, seconds.
  double max_position_m = 1000;        ///< |position| at most this, metres.
};

/// The world_from_eye of a tracker's PoseStamped. Throws MessageError naming
/// the field: a frame other than check.frame_id, a stamp more than max_skew_s
/// from now (or nanosec >= 1e9), a position not finite or past
/// max_position_m, an orientation not finite or whose norm is not 1 within
/// 1e-3 (it is then normalized).
Rigid3d HeadFromPoseStamped(const geometry_msgs_msg_dds__PoseStamped_& pose, const PoseCheck& check);

/// The same of a tf transform parent -> child (the child frame a tracker
/// publishes on /tf: parent_from_child is the pose), checked as a pose.
Rigid3d HeadFromTransform(const geometry_msgs_msg_dds__TransformStamped_& transform, const PoseCheck& check);

/// hullpipe_msgs/EyeViews (ros2/hullpipe_msgs/msg/EyeViews.msg) of both eyes'
/// views as a headset client publishes them: header stamped views.stamp_ns in
/// `frame_id`, each eye's XrPosef (position in metres; orientation in OpenXR's
/// view axes, XrOrientationOf the OpenCV world_from_eye) and XrFovf (radians,
/// as float32). views.tracker_id is not on the wire (the bridge's --tracker-id).
RosSample<hullpipe_msgs_msg_dds__EyeViews_> MakeEyeViews(const EyeViewsSample& views, const std::string& frame_id);

/// The views a headset client's hullpipe_msgs/EyeViews gives render_node
/// (docs/hmd.md), as tracker `tracker_id`: each eye's world_from_eye in
/// OpenCV's eye axes (EyePoseFromXr) and its XrFovf. Throws MessageError
/// naming the field, as HeadFromPoseStamped: header.frame_id other than
/// check.frame_id, header.stamp more than check.max_skew_s from now (or
/// nanosec >= 1e9), views[k].pose.position not finite or past
/// check.max_position_m, views[k].pose.orientation not finite or whose norm is
/// not 1 within 1e-3, views[k]'s field of view not finite or not a frustum
/// (EyeFov::Check).
EyeViewsSample EyeViewsFromRos2(const hullpipe_msgs_msg_dds__EyeViews_& views, const PoseCheck& check,
                                uint32_t tracker_id);

/// Most transforms of one /tf message looked at (the rest counted, not read):
/// a flood of frames costs a bounded time per message.
inline constexpr uint32_t kMaxTransformsPerMessage = 1000;

}  // namespace hullpipe::ros2
