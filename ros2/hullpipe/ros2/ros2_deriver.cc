#include "hullpipe/ros2/ros2_deriver.h"

#include <opencv2/imgcodecs.hpp>

#include "hullpipe/dds/convert.h"
#include "hullpipe/ros2/ros2_messages.h"
#include "hullpipe/ros2/ros2_topics.h"

namespace hullpipe::ros2 {

namespace {
std::string CameraBase(uint32_t id) { return "/hullpipe/cam" + std::to_string(id); }
// The quality a camera image's region goes out with in its whole image (the
// quality capture_node's JPEGs have by default).
constexpr int kRegionJpegQuality = 90;
}  // namespace

template <typename F>
std::string Ros2Deriver::Guard(F&& f) {
  try {
    f();
    return "";
  } catch (const dds::MessageError& e) {
    ++counts_.refused;
    return e.what();
  }
}

const Camera* Ros2Deriver::camera(int id) const {
  const auto it = cameras_.find(id);
  return it == cameras_.end() ? nullptr : &it->second;
}

std::string Ros2Deriver::OnCameraInfo(const hullpipe_msg_CameraInfo& m, int64_t now_ns) {
  return Guard([&] {
    const Camera c = dds::CameraFromMsg(m, nullptr);
    if (!cameras_.count(c.id) && cameras_.size() >= kMaxCameras) {
      ++counts_.cameras_refused;
      throw dds::MessageError("camera " + std::to_string(c.id) + ": more than " + std::to_string(kMaxCameras) +
                              " cameras");
    }
    cameras_[c.id] = c;
    std::vector<Camera> all;
    for (const auto& [id, cam] : cameras_) all.push_back(cam);
    const auto tf = MakeCameraTransforms(all, now_ns);
    emit_({"/tf_static", "tf2_msgs/msg/TFMessage", kTfStaticQos, &tf.msg, now_ns});
  });
}

std::string Ros2Deriver::OnMap(const hullpipe_msg_ObjectPixelMap& m) {
  return Guard([&] {
    const auto cam = cameras_.find(int(m.camera_id));
    if (cam == cameras_.end()) return;  // its calibration first (transient-local: it comes)
    const std::string base = CameraBase(m.camera_id);
    const auto info = MakeCameraInfo(cam->second, m.capture_time_ns);
    emit_({base + "/camera_info", "sensor_msgs/msg/CameraInfo", kDefaultQos, &info.msg, m.capture_time_ns});
    if (!o_.maps) return;
    const auto map = MakeMono8Image(dds::MapFromMsg(m), m.capture_time_ns, CameraFrameId(cam->first));
    emit_({base + "/object_pixel_map", "sensor_msgs/msg/Image", kDefaultQos, &map.msg, m.capture_time_ns});
  });
}

std::string Ros2Deriver::OnImage(const hullpipe_msg_CameraImage& m) {
  return Guard([&] {
    const auto cam = cameras_.find(int(m.camera_id));
    if (!o_.images || cam == cameras_.end()) return;
    dds::CheckImageWithin(m, cam->second.width, cam->second.height);  // before a region's whole image is made
    const std::string base = CameraBase(m.camera_id), frame = CameraFrameId(int(m.camera_id));
    if (m.encoding == hullpipe_msg_IMAGE_ENCODING_JPEG) {
      // Passed on as they are, once checked to be a JPEG of the stated size.
      // A region (capture_node --image-region) goes out as its whole image,
      // black around it, encoded again: a ROS 2 image is the camera's whole.
      std::vector<uint8_t> bytes;
      if (dds::ImageHasRegion(m)) {
        if (!cv::imencode(".jpg", dds::ImageFromMsg(m), bytes, {cv::IMWRITE_JPEG_QUALITY, kRegionJpegQuality}))
          throw dds::MessageError("CameraImage: the JPEG encoder failed");
      } else {
        dds::CheckJpegOfSize("CameraImage: ", m.data._buffer, m.data._length, m.width, m.height);
        bytes.assign(m.data._buffer, m.data._buffer + m.data._length);
      }
      const auto jpeg = MakeCompressedImage(std::move(bytes), m.capture_time_ns, frame);
      emit_({base + "/image/compressed", "sensor_msgs/msg/CompressedImage", kDefaultQos, &jpeg.msg,
             m.capture_time_ns});
    } else {
      const auto raw = MakeBgr8Image(dds::ImageFromMsg(m), m.capture_time_ns, frame);
      emit_({base + "/image", "sensor_msgs/msg/Image", kDefaultQos, &raw.msg, m.capture_time_ns});
    }
  });
}

std::string Ros2Deriver::OnViewPose(const hullpipe_msg_ViewPose& m) {
  return Guard([&] {
    const NovelView view = dds::ViewFromMsg(m);
    const ViewEye eye = ViewEye(m.eye);  // checked by ViewFromMsg
    views_[m.pose_seq] = {view, eye};
    while (views_.size() > 256) views_.erase(views_.begin());
    if (!o_.view) return;
    const auto tf = MakeViewTransform(view.world_from_eye, m.stamp_ns, eye);
    emit_({"/tf", "tf2_msgs/msg/TFMessage", kDefaultQos, &tf.msg, m.stamp_ns});
  });
}

std::string Ros2Deriver::OnHullView(const hullpipe_msg_HullView& m) {
  return Guard([&] {
    if (!o_.hull_points) return;
    const uint64_t pose = m.pose_seq;
    const auto whole = tiles_.Add(dds::TileFromMsg(m));
    if (!whole) return;
    const auto view = views_.find(pose);
    if (view == views_.end()) return;  // its pose not seen: nowhere to put the points
    // One cloud per frameset: a stereo pair's right eye sees the same hull from
    // an IPD aside, in the same world frame.
    if (view->second.eye == ViewEye::kRight) return;
    const auto cloud = MakeHullPointCloud(view->second.view, whole->depth, whole->colour, o_.hull_point_stride,
                                          m.capture_time_ns);
    emit_({"/hullpipe/hull_points", "sensor_msgs/msg/PointCloud2", kDefaultQos, &cloud.msg, m.capture_time_ns});
  });
}

std::string Ros2Deriver::OnCompositedView(const hullpipe_msg_CompositedView& m) {
  return Guard([&] {
    if (!o_.view) return;
    dds::CheckCompositedViewMsg(m);  // render_node's JPEG, passed on once its header is checked
    const ViewEye eye = ViewEye(m.eye);  // checked just now
    const auto jpeg = MakeCompressedImage(std::vector<uint8_t>(m.data._buffer, m.data._buffer + m.data._length),
                                          m.capture_time_ns, ViewFrameId(eye));
    emit_({ViewImageTopic(eye), "sensor_msgs/msg/CompressedImage", kDefaultQos, &jpeg.msg, m.capture_time_ns});
  });
}

std::string Ros2Deriver::OnObjectState(const hullpipe_msg_VirtualObjectState& m) {
  return Guard([&] {
    if (!o_.markers) return;
    const auto marker = MakeObjectMarker(dds::VirtualObjectFromMsg(m), m.capture_time_ns);
    emit_({"/hullpipe/markers", "visualization_msgs/msg/MarkerArray", kDefaultQos, &marker.msg, m.capture_time_ns});
  });
}

std::string Ros2Deriver::OnCollisionReport(const hullpipe_msg_CollisionReport& m) {
  return Guard([&] {
    if (!o_.markers && !o_.collisions) return;
    const CollisionReportSample report = dds::CollisionReportFromMsg(m);
    if (o_.markers) {
      const auto marker = MakeContactMarker(report.object_id, report.collision_points, report.capture_time_ns);
      emit_({"/hullpipe/markers", "visualization_msgs/msg/MarkerArray", kDefaultQos, &marker.msg,
             report.capture_time_ns});
    }
    if (o_.collisions) {
      const auto ros = MakeCollisionReport(report);
      emit_({"/hullpipe/collisions", "hullpipe_msgs/msg/CollisionReport", kDefaultQos, &ros.msg,
             report.capture_time_ns});
    }
  });
}

std::string Ros2Deriver::OnMesh(const hullpipe_msg_VirtualMesh& m) {
  return Guard([&] {
    if (!o_.markers) return;
    const auto marker = MakeMeshMarker(dds::VirtualMeshFromMsg(m), m.capture_time_ns);
    emit_({"/hullpipe/markers", "visualization_msgs/msg/MarkerArray", kDefaultQos, &marker.msg, m.capture_time_ns});
  });
}

std::string Ros2Deriver::OnModelPart(const hullpipe_msg_ModelPart& m) {
  return Guard([&] {
    if (!o_.markers) return;
    ModelPartSample part = dds::ModelPartFromMsg(m);
    const auto known = parts_.find(part.object_id);
    const size_t before = known == parts_.end() ? 0 : known->second.part.triangles.size();
    if ((known == parts_.end() && parts_.size() >= kMaxModelParts) ||
        part_triangles_ - before + part.triangles.size() > kMaxModelTriangles) {
      ++counts_.parts_refused;
      throw dds::MessageError("ModelPart " + std::to_string(part.object_id) + ": past the markers' bound (" +
                              std::to_string(kMaxModelParts) + " parts, " + std::to_string(kMaxModelTriangles) +
                              " triangles in all): not drawn");
    }
    part_triangles_ = part_triangles_ - before + part.triangles.size();
    parts_[part.object_id].part = std::move(part);
    parts_changed_ = true;
  });
}

std::string Ros2Deriver::OnModelState(const hullpipe_msg_ModelState& m) {
  return Guard([&] {
    if (!o_.markers) return;
    const ModelStateSample state = dds::ModelStateFromMsg(m);
    // Only the parts whose geometry came (at most kMaxModelParts): their frames.
    std::vector<bool> known(state.parts.size(), false);
    bool any = false;
    for (size_t i = 0; i < state.parts.size() && i < kMaxModelParts; ++i) {
      const auto it = parts_.find(state.model_id + uint32_t(i));
      if (it == parts_.end()) continue;
      known[i] = any = true;
      if (it->second.contact != state.parts[i].contact) parts_changed_ = true;
      it->second.contact = state.parts[i].contact;
    }
    if (!any) return;
    const int64_t t = state.capture_time_ns;
    const auto tf = MakePartTransforms(state, known);
    emit_({"/tf", "tf2_msgs/msg/TFMessage", kDefaultQos, &tf.msg, t});
    const bool due = parts_sent_ns_ == INT64_MIN || t < parts_sent_ns_ ||
                     double(t - parts_sent_ns_) * 1e-9 >= o_.model_marker_period_s;
    if (!parts_changed_ || !due) return;
    std::vector<PartDrawing> drawings;
    drawings.reserve(parts_.size());
    for (const auto& [id, p] : parts_) drawings.push_back({&p.part, p.contact});
    const auto markers = MakeModelMarkers(drawings, t);
    emit_({"/hullpipe/model_markers", "visualization_msgs/msg/MarkerArray", kLatchedQos, &markers.msg, t});
    parts_changed_ = false;
    parts_sent_ns_ = t;
  });
}

}  // namespace hullpipe::ros2
