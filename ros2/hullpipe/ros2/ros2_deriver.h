// hullpipe's samples as ROS 2 messages, one place for both the live bridge
// (ros2_bridge.h, hullpipe_ros2) and the bag export (`hullpipe_record export
// --ros2`): it keeps what a message needs from earlier samples (each camera's
// calibration, the views' poses, the tiles of a view) and hands each ROS 2
// message to a callback with its topic, type and QoS (docs/ros2.md's table).
// Bounded: at most kMaxCameras cameras (a later one is refused and counted),
// 256 view poses, the tiles TileSet holds, kMaxModelParts model parts of at
// most kMaxModelTriangles triangles in all (a later part is refused and
// counted).
#pragma once

#include <climits>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "hullpipe.h"  // idlc-generated: hullpipe's own types
#include "hullpipe/dds/dds.h"
#include "hullpipe/geometry/calibration.h"
#include "hullpipe/geometry/camera.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/stereo_views.h"
#include "hullpipe/reconstruction/tile_set.h"

namespace hullpipe::ros2 {

/// One ROS 2 message to publish or record; `msg` is valid during the call.
struct Ros2Message {
  std::string topic;  ///< The ROS 2 name ("/hullpipe/cam1/camera_info").
  std::string type;   ///< "sensor_msgs/msg/CameraInfo" (ros2_schemas.h Ros2TypeNames).
  dds::QosSpec qos;
  const void* msg = nullptr;  ///< The idlc struct of `type`.
  int64_t stamp_ns = 0;       ///< Its header's stamp.
};

struct Ros2DeriverOptions {
  bool maps = true;         ///< Object-pixel maps (mono8).
  bool images = true;       ///< Camera frames (bgr8, or the JPEG).
  bool view = true;         ///< The composited view (JPEG) and /tf's view pose.
  bool hull_points = true;  ///< The hull as a point cloud from the view's tiles.
  int hull_point_stride = 4;  ///< Every this many pixels, each way.
  bool markers = true;      ///< Virtual objects, meshes, model parts and contacts as markers.
  bool collisions = true;   ///< Collision reports (hullpipe_msgs/CollisionReport).
  /// Least capture-time interval between two /hullpipe/model_markers messages
  /// (each carries every part's geometry, sent again when a part's contact
  /// state changes), seconds; a change within it is sent at the first model
  /// state after it.
  double model_marker_period_s = 0.2;
};

/// What a derivation refused or left out, counted.
struct Ros2DeriverCounts {
  uint64_t cameras_refused = 0;  ///< Cameras past kMaxCameras.
  uint64_t refused = 0;          ///< Samples that did not convert (MessageError).
  uint64_t parts_refused = 0;    ///< Model parts past kMaxModelParts or kMaxModelTriangles.
};

class Ros2Deriver {
 public:
  static constexpr size_t kMaxCameras = Rig::kMaxCameras;
  /// Model parts drawn as markers, and their triangles in all (a marker array
  /// of 500,000 triangles is 36 MB).
  static constexpr size_t kMaxModelParts = 4096, kMaxModelTriangles = 500000;
  using Emit = std::function<void(const Ros2Message&)>;
  Ros2Deriver(Ros2DeriverOptions options, Emit emit) : o_(options), emit_(std::move(emit)) {}

  /// Each takes one of hullpipe's samples (as it arrives, in order) and emits
  /// what it gives. A sample that does not convert is counted (counts()) and
  /// its MessageError's text returned; "" otherwise.
  std::string OnCameraInfo(const hullpipe_msg_CameraInfo& m, int64_t now_ns);
  std::string OnMap(const hullpipe_msg_ObjectPixelMap& m);
  std::string OnImage(const hullpipe_msg_CameraImage& m);
  std::string OnViewPose(const hullpipe_msg_ViewPose& m);
  std::string OnHullView(const hullpipe_msg_HullView& m);
  std::string OnCompositedView(const hullpipe_msg_CompositedView& m);
  std::string OnObjectState(const hullpipe_msg_VirtualObjectState& m);
  std::string OnCollisionReport(const hullpipe_msg_CollisionReport& m);
  std::string OnMesh(const hullpipe_msg_VirtualMesh& m);
  std::string OnModelPart(const hullpipe_msg_ModelPart& m);
  std::string OnModelState(const hullpipe_msg_ModelState& m);

  const Ros2DeriverCounts& counts() const { return counts_; }
  /// A camera's calibration as last received (nullptr: none).
  const Camera* camera(int id) const;

 private:
  template <typename F>
  std::string Guard(F&& f);
  Ros2DeriverOptions o_;
  Emit emit_;
  std::map<int, Camera> cameras_;
  struct View {
    NovelView view;
    ViewEye eye = ViewEye::kMono;
  };
  std::map<uint64_t, View> views_;  // pose_seq -> view, newest 256
  TileSet tiles_;
  struct Part {
    ModelPartSample part;
    uint8_t contact = 0;
  };
  std::map<uint32_t, Part> parts_;  // by object id
  size_t part_triangles_ = 0;
  bool parts_changed_ = false;          // since the last model markers
  int64_t parts_sent_ns_ = INT64_MIN;   // capture time of the last model markers
  Ros2DeriverCounts counts_;
};

}  // namespace hullpipe::ros2
