#include "hullpipe/ros2/ros2_messages.h"

#include <cmath>
#include <cstring>

#include <Eigen/Geometry>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/reconstruction/tile_set.h"

namespace hullpipe::ros2 {

namespace {

// Points a message's string field at strings[k] (reserved by the caller).
char* Text(std::vector<std::string>* strings, std::string s) {
  strings->push_back(std::move(s));
  return const_cast<char*>(strings->back().c_str());
}

std_msgs_msg_dds__Header_ Header(std::vector<std::string>* strings, int64_t stamp_ns, const std::string& frame_id) {
  std_msgs_msg_dds__Header_ h{};
  h.stamp = RosTime(stamp_ns);
  h.frame_id = Text(strings, frame_id);
  return h;
}

geometry_msgs_msg_dds__Quaternion_ Quaternion(const Eigen::Matrix3d& r) {
  const Eigen::Quaterniond q = Eigen::Quaterniond(r).normalized();
  return {q.x(), q.y(), q.z(), q.w()};
}

// tf's transform kWorldFrame -> `child` of world_from_child.
geometry_msgs_msg_dds__TransformStamped_ WorldTransform(std::vector<std::string>* strings, int64_t stamp_ns,
                                                        const std::string& child, const Rigid3d& world_from_child) {
  geometry_msgs_msg_dds__TransformStamped_ t{};
  t.header = Header(strings, stamp_ns, kWorldFrame);
  t.child_frame_id = Text(strings, child);
  t.transform.translation = {world_from_child.translation.x(), world_from_child.translation.y(),
                             world_from_child.translation.z()};
  t.transform.rotation = Quaternion(world_from_child.rotation);
  return t;
}

}  // namespace

std::string CameraFrameId(int id) { return "hullpipe_cam" + std::to_string(id); }

builtin_interfaces_msg_dds__Time_ RosTime(int64_t ns) {
  int64_t sec = ns / 1000000000, rem = ns % 1000000000;
  if (rem < 0) rem += 1000000000, --sec;
  return {int32_t(sec), uint32_t(rem)};
}

int64_t NanosecondsOf(const builtin_interfaces_msg_dds__Time_& t) {
  if (t.nanosec >= 1000000000u) throw dds::MessageError("stamp.nanosec " + std::to_string(t.nanosec) + " >= 1e9");
  return int64_t(t.sec) * 1000000000 + int64_t(t.nanosec);
}

RosSample<sensor_msgs_msg_dds__CameraInfo_> MakeCameraInfo(const Camera& c, int64_t stamp_ns) {
  RosSample<sensor_msgs_msg_dds__CameraInfo_> s;
  s.strings.reserve(2);
  auto& m = s.msg;
  m.header = Header(&s.strings, stamp_ns, CameraFrameId(c.id));
  m.height = uint32_t(c.height);
  m.width = uint32_t(c.width);
  m.distortion_model = Text(&s.strings, "plumb_bob");
  s.doubles.assign(c.distortion.begin(), c.distortion.end());
  dds::Borrow(&m.d, s.doubles);
  // ROS pixel centres at integers: the principal point moves by half a pixel.
  const double cx = c.cx - kOpenCvToHullpipePixelOffset, cy = c.cy - kOpenCvToHullpipePixelOffset;
  const double k[9] = {c.fx, c.skew, cx, 0, c.fy, cy, 0, 0, 1};
  std::memcpy(m.k, k, sizeof k);
  const double r[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  std::memcpy(m.r, r, sizeof r);
  const double p[12] = {c.fx, c.skew, cx, 0, 0, c.fy, cy, 0, 0, 0, 1, 0};
  std::memcpy(m.p, p, sizeof p);
  m.binning_x = m.binning_y = 0;  // ROS: 0 and 1 both mean no binning
  m.roi = {0, 0, 0, 0, false};    // all zeros: the full image
  return s;
}

namespace {

// sensor_msgs/Image of an 8-bit image, rows packed (step = width * channels).
RosSample<sensor_msgs_msg_dds__Image_> PackedImage(const cv::Mat& image, int64_t stamp_ns, const std::string& frame_id,
                                                   const char* encoding) {
  RosSample<sensor_msgs_msg_dds__Image_> s;
  s.strings.reserve(2);
  auto& m = s.msg;
  m.header = Header(&s.strings, stamp_ns, frame_id);
  m.height = uint32_t(image.rows);
  m.width = uint32_t(image.cols);
  m.encoding = Text(&s.strings, encoding);
  m.is_bigendian = 0;
  const size_t row = size_t(image.cols) * image.elemSize();
  m.step = uint32_t(row);
  s.bytes.resize(row * size_t(image.rows));
  for (int r = 0; r < image.rows; ++r) std::memcpy(s.bytes.data() + size_t(r) * row, image.ptr(r), row);
  dds::Borrow(&m.data, s.bytes);
  return s;
}

}  // namespace

RosSample<sensor_msgs_msg_dds__Image_> MakeMono8Image(const cv::Mat& map, int64_t stamp_ns,
                                                      const std::string& frame_id) {
  if (map.empty() || map.type() != CV_8UC1) throw dds::MessageError("Image: an object-pixel map is CV_8UC1");
  return PackedImage(map, stamp_ns, frame_id, "mono8");
}

RosSample<sensor_msgs_msg_dds__Image_> MakeBgr8Image(const cv::Mat& bgr, int64_t stamp_ns,
                                                     const std::string& frame_id) {
  if (bgr.empty() || bgr.type() != CV_8UC3) throw dds::MessageError("Image: a camera frame is CV_8UC3");
  return PackedImage(bgr, stamp_ns, frame_id, "bgr8");
}

RosSample<sensor_msgs_msg_dds__CompressedImage_> MakeCompressedImage(std::vector<uint8_t> jpeg, int64_t stamp_ns,
                                                                     const std::string& frame_id) {
  if (jpeg.empty()) throw dds::MessageError("CompressedImage: no bytes");
  RosSample<sensor_msgs_msg_dds__CompressedImage_> s;
  s.strings.reserve(2);
  s.msg.header = Header(&s.strings, stamp_ns, frame_id);
  s.msg.format = Text(&s.strings, "jpeg");
  s.bytes = std::move(jpeg);
  dds::Borrow(&s.msg.data, s.bytes);
  return s;
}

RosSample<tf2_msgs_msg_dds__TFMessage_> MakeCameraTransforms(const std::vector<Camera>& cameras, int64_t stamp_ns) {
  RosSample<tf2_msgs_msg_dds__TFMessage_> s;
  s.strings.reserve(2 * cameras.size());
  for (const Camera& c : cameras)
    s.transforms.push_back(WorldTransform(&s.strings, stamp_ns, CameraFrameId(c.id), c.cam_from_world.Inverse()));
  dds::Borrow(&s.msg.transforms, s.transforms);
  return s;
}

RosSample<geometry_msgs_msg_dds__PoseStamped_> MakePoseStamped(const Rigid3d& world_from_eye, int64_t stamp_ns,
                                                               const std::string& frame_id) {
  RosSample<geometry_msgs_msg_dds__PoseStamped_> s;
  s.strings.reserve(1);
  s.msg.header = Header(&s.strings, stamp_ns, frame_id);
  s.msg.pose.position = {world_from_eye.translation.x(), world_from_eye.translation.y(),
                         world_from_eye.translation.z()};
  s.msg.pose.orientation = Quaternion(world_from_eye.rotation);
  return s;
}

std::string ViewFrameId(ViewEye eye) {
  return ForEye(kViewFrame, eye, '_');
}

std::string ViewImageTopic(ViewEye eye) {
  return ForEye("/hullpipe/view", eye, '/') + "/compressed";
}

RosSample<tf2_msgs_msg_dds__TFMessage_> MakeViewTransform(const Rigid3d& world_from_eye, int64_t stamp_ns,
                                                          ViewEye eye) {
  RosSample<tf2_msgs_msg_dds__TFMessage_> s;
  s.strings.reserve(2);
  s.transforms.push_back(WorldTransform(&s.strings, stamp_ns, ViewFrameId(eye), world_from_eye));
  dds::Borrow(&s.msg.transforms, s.transforms);
  return s;
}

RosSample<sensor_msgs_msg_dds__PointCloud2_> MakeHullPointCloud(const NovelView& view, const cv::Mat& depth,
                                                                const cv::Mat& colour, int stride, int64_t stamp_ns) {
  if (depth.type() != CV_32FC1 || colour.type() != CV_8UC3 || depth.size() != colour.size() || stride < 1)
    throw dds::MessageError("PointCloud2: depth CV_32FC1 and colour CV_8UC3 of one size, stride >= 1");
  RosSample<sensor_msgs_msg_dds__PointCloud2_> s;
  s.strings.reserve(5);
  auto& m = s.msg;
  m.header = Header(&s.strings, stamp_ns, kWorldFrame);
  uint32_t offset = 0;
  for (const char* name : {"x", "y", "z", "rgb"}) {
    s.fields.push_back({Text(&s.strings, name), offset, 7 /* FLOAT32 */, 1});
    offset += 4;
  }
  dds::Borrow(&m.fields, s.fields);
  uint32_t n = 0;
  for (int v = 0; v < depth.rows; v += stride)
    for (int u = 0; u < depth.cols; u += stride) {
      const float z = depth.at<float>(v, u);
      if (!(z > 0) || !std::isfinite(z) || z >= kNoDepth) continue;
      // Pixel centres at +0.5 (geometry/conventions.h).
      const Eigen::Vector3d p = view.world_from_eye * (view.EyeRay(u + 0.5, v + 0.5) * double(z));
      const cv::Vec3b bgr = colour.at<cv::Vec3b>(v, u);
      const uint32_t rgb = uint32_t(bgr[2]) << 16 | uint32_t(bgr[1]) << 8 | uint32_t(bgr[0]);
      float point[4] = {float(p.x()), float(p.y()), float(p.z()), 0};
      std::memcpy(&point[3], &rgb, 4);
      const auto* b = reinterpret_cast<const uint8_t*>(point);
      s.bytes.insert(s.bytes.end(), b, b + sizeof point);
      ++n;
    }
  m.height = 1;
  m.width = n;
  m.is_bigendian = false;
  m.point_step = 16;
  m.row_step = 16 * n;
  dds::Borrow(&m.data, s.bytes);
  m.is_dense = true;
  return s;
}

namespace {

std_msgs_msg_dds__ColorRGBA_ Rgba(const cv::Vec3b& bgr) {
  return {float(bgr[2]) / 255.f, float(bgr[1]) / 255.f, float(bgr[0]) / 255.f, 1.f};
}
constexpr std_msgs_msg_dds__ColorRGBA_ kRed{0.9f, 0.1f, 0.1f, 1.f};

// One marker of the array, its strings in s.strings (reserved by the caller).
visualization_msgs_msg_dds__Marker_& OneMarker(RosSample<visualization_msgs_msg_dds__MarkerArray_>* s,
                                               const char* ns, uint32_t id, int32_t type, int64_t stamp_ns) {
  visualization_msgs_msg_dds__Marker_ m{};
  m.header = Header(&s->strings, stamp_ns, kWorldFrame);
  m.ns = Text(&s->strings, ns);
  m.id = int32_t(id & 0x7fffffff);
  m.type = type;
  m.action = 0;  // ADD (or modify)
  m.pose.orientation.w = 1;
  m.texture_resource = Text(&s->strings, "");
  m.texture.header = Header(&s->strings, 0, "");
  m.texture.format = Text(&s->strings, "");
  m.text = Text(&s->strings, "");
  m.mesh_resource = Text(&s->strings, "");
  m.mesh_file.filename = Text(&s->strings, "");
  s->markers.push_back(m);
  dds::Borrow(&s->msg.markers, s->markers);
  return s->markers.back();
}

}  // namespace

RosSample<visualization_msgs_msg_dds__MarkerArray_> MakeObjectMarker(const VirtualObjectSample& o, int64_t stamp_ns) {
  RosSample<visualization_msgs_msg_dds__MarkerArray_> s;
  s.strings.reserve(16);
  const bool box = o.shape == VirtualObjectSample::Shape::kBox;
  auto& m = OneMarker(&s, "hullpipe_objects", o.object_id, box ? 1 /* CUBE */ : 2 /* SPHERE */, stamp_ns);
  m.pose.position = {o.position.x(), o.position.y(), o.position.z()};
  const Eigen::Quaterniond q = o.orientation.normalized();
  m.pose.orientation = {q.x(), q.y(), q.z(), q.w()};
  m.scale = box ? geometry_msgs_msg_dds__Vector3_{2 * o.half_extents.x(), 2 * o.half_extents.y(),
                                                   2 * o.half_extents.z()}
                : geometry_msgs_msg_dds__Vector3_{2 * o.radius, 2 * o.radius, 2 * o.radius};
  m.color = o.colliding ? kRed : std_msgs_msg_dds__ColorRGBA_{0.16f, 0.7f, 0.86f, 1.f};
  return s;
}

RosSample<visualization_msgs_msg_dds__MarkerArray_> MakeMeshMarker(const VirtualMeshSample& mesh, int64_t stamp_ns) {
  RosSample<visualization_msgs_msg_dds__MarkerArray_> s;
  s.strings.reserve(16);
  const VirtualMeshDraw& d = mesh.draw;
  const bool points = d.triangles.empty();
  auto& m = OneMarker(&s, "hullpipe_meshes", mesh.object_id, points ? 7 /* SPHERE_LIST */ : 11 /* TRIANGLE_LIST */,
                      stamp_ns);
  const double size = points ? 2 * d.point_radius : 1.0;
  m.scale = {size, size, size};
  m.color = Rgba(d.colour);
  auto flagged = [&](size_t i) { return i < d.colliding.size() && d.colliding[i] != 0; };
  if (points) {
    for (size_t i = 0; i < d.vertices.size(); ++i) {
      s.points.push_back({d.vertices[i].x(), d.vertices[i].y(), d.vertices[i].z()});
      s.colors.push_back(flagged(i) ? kRed : Rgba(d.colour));
    }
  } else {
    for (size_t t = 0; t < d.triangles.size(); ++t)
      for (int k = 0; k < 3; ++k) {
        const int i = d.triangles[t][k];
        if (i < 0 || size_t(i) >= d.vertices.size()) continue;  // validated at the wire
        s.points.push_back({d.vertices[size_t(i)].x(), d.vertices[size_t(i)].y(), d.vertices[size_t(i)].z()});
        s.colors.push_back(flagged(t) ? kRed : Rgba(d.colour));
      }
  }
  dds::Borrow(&m.points, s.points);
  dds::Borrow(&m.colors, s.colors);
  return s;
}

RosSample<visualization_msgs_msg_dds__MarkerArray_> MakeContactMarker(uint32_t object_id,
                                                                      const std::vector<Eigen::Vector3d>& points,
                                                                      int64_t stamp_ns) {
  RosSample<visualization_msgs_msg_dds__MarkerArray_> s;
  s.strings.reserve(16);
  auto& m = OneMarker(&s, "hullpipe_contacts", object_id, 7 /* SPHERE_LIST */, stamp_ns);
  m.scale = {0.01, 0.01, 0.01};
  m.color = kRed;
  for (const auto& p : points) s.points.push_back({p.x(), p.y(), p.z()});
  dds::Borrow(&m.points, s.points);
  return s;
}

std::string PartFrameId(uint32_t object_id) { return "hullpipe_part" + std::to_string(object_id); }

RosSample<tf2_msgs_msg_dds__TFMessage_> MakePartTransforms(const ModelStateSample& state,
                                                           const std::vector<bool>& known) {
  RosSample<tf2_msgs_msg_dds__TFMessage_> s;
  s.strings.reserve(2 * state.parts.size());
  for (size_t i = 0; i < state.parts.size(); ++i) {
    if (!known.empty() && (i >= known.size() || !known[i])) continue;
    const PartStateSample& p = state.parts[i];
    Rigid3d world_from_body;
    world_from_body.rotation =
        Eigen::Quaterniond(p.orientation[0], p.orientation[1], p.orientation[2], p.orientation[3])
            .normalized()
            .toRotationMatrix();
    world_from_body.translation = p.position;
    s.transforms.push_back(WorldTransform(&s.strings, state.capture_time_ns,
                                          PartFrameId(state.model_id + uint32_t(i)), world_from_body));
  }
  dds::Borrow(&s.msg.transforms, s.transforms);
  return s;
}

RosSample<visualization_msgs_msg_dds__MarkerArray_> MakeModelMarkers(const std::vector<PartDrawing>& parts,
                                                                     int64_t stamp_ns) {
  RosSample<visualization_msgs_msg_dds__MarkerArray_> s;
  size_t points = 0;
  for (const PartDrawing& d : parts) points += 3 * d.part->triangles.size();
  // Every marker's string and point storage reserved first: the markers point into it.
  s.strings.reserve(10 * parts.size());  // OneMarker's 8 and the part's frame
  s.markers.reserve(parts.size());
  s.points.reserve(points);
  for (const PartDrawing& d : parts) {
    const ModelPartSample& part = *d.part;
    auto& m = OneMarker(&s, "hullpipe_models", part.object_id, 11 /* TRIANGLE_LIST */, stamp_ns);
    m.header.frame_id = Text(&s.strings, PartFrameId(part.object_id));
    m.frame_locked = true;
    m.scale = {1, 1, 1};
    m.color = d.contact == kPartColliding ? kRed
              : d.contact == kPartNear    ? std_msgs_msg_dds__ColorRGBA_{1.f, 0.62f, 0.f, 1.f}
                                          : Rgba(part.colour);
    const size_t first = s.points.size();
    for (const Eigen::Vector3i& t : part.triangles)
      for (int k = 0; k < 3; ++k) {
        const int i = t[k];
        if (i < 0 || size_t(i) >= part.vertices.size()) continue;  // validated at the wire
        const Eigen::Vector3f& v = part.vertices[size_t(i)];
        s.points.push_back({v.x(), v.y(), v.z()});
      }
    m.points._buffer = s.points.data() + first;
    m.points._length = m.points._maximum = uint32_t(s.points.size() - first);
    m.points._release = false;
  }
  return s;
}

RosSample<hullpipe_msgs_msg_dds__CollisionReport_> MakeCollisionReport(const CollisionReportSample& r) {
  RosSample<hullpipe_msgs_msg_dds__CollisionReport_> s;
  s.strings.reserve(1);
  auto& m = s.msg;
  m.header = Header(&s.strings, r.capture_time_ns, kWorldFrame);
  m.object_id = r.object_id;
  m.frame_seq = r.frame_seq;
  s.uints = r.triangle_ids;
  dds::Borrow(&m.triangle_ids, s.uints);
  for (const auto& p : r.collision_points) s.points.push_back({p.x(), p.y(), p.z()});
  dds::Borrow(&m.collision_points, s.points);
  m.has_response = r.has_response;
  m.cp_obj = {r.cp_obj.x(), r.cp_obj.y(), r.cp_obj.z()};
  m.cp_hull = {r.cp_hull.x(), r.cp_hull.y(), r.cp_hull.z()};
  m.v_rec = {r.v_rec.x(), r.v_rec.y(), r.v_rec.z()};
  m.d_rec = r.d_rec;
  m.n_hull = {r.n_hull.x(), r.n_hull.y(), r.n_hull.z()};
  m.hull_velocity_status = r.hull_velocity_status;
  m.hull_normal_speed = r.hull_normal_speed;
  m.hull_velocity_interval = r.hull_velocity_interval;
  return s;
}

namespace {

// A tracker's header as PoseCheck says: its frame, and its stamp near now.
// `what` leads the message ("PoseStamped").
void CheckHeader(const std_msgs_msg_dds__Header_& h, const PoseCheck& check, const std::string& what) {
  const std::string frame = h.frame_id ? std::string(h.frame_id, strnlen(h.frame_id, 256)) : "";
  if (frame != check.frame_id)
    throw dds::MessageError(what + ": header.frame_id '" + frame.substr(0, 64) + "' is not '" + check.frame_id +
                            "' (poses in other frames are not looked up)");
  const int64_t stamp = NanosecondsOf(h.stamp);
  const double skew_s = double(stamp - check.now_ns) * 1e-9;
  if (!(std::abs(skew_s) <= check.max_skew_s))
    throw dds::MessageError(what + ": header.stamp is " + std::to_string(skew_s) + " s from now (at most " +
                            std::to_string(check.max_skew_s) + ")");
}

// A tracker's pose as PoseCheck says: a finite position within the bound, a
// unit orientation (1e-3), then normalized. `field` names it ("pose").
Rigid3d CheckedPose(const geometry_msgs_msg_dds__Pose_& pose, const PoseCheck& check, const std::string& what,
                    const std::string& field) {
  const Eigen::Vector3d p(pose.position.x, pose.position.y, pose.position.z);
  if (!p.allFinite() || !(p.norm() <= check.max_position_m))
    throw dds::MessageError(what + ": " + field + ".position not finite or past " +
                            std::to_string(check.max_position_m) + " m");
  const Eigen::Quaterniond q(pose.orientation.w, pose.orientation.x, pose.orientation.y, pose.orientation.z);
  if (!q.coeffs().allFinite() || !(std::abs(q.norm() - 1) <= 1e-3))
    throw dds::MessageError(what + ": " + field + ".orientation is not a unit quaternion");
  Rigid3d world_from_pose;
  world_from_pose.rotation = q.normalized().toRotationMatrix();
  world_from_pose.translation = p;
  return world_from_pose;
}

}  // namespace

Rigid3d HeadFromPoseStamped(const geometry_msgs_msg_dds__PoseStamped_& m, const PoseCheck& check) {
  CheckHeader(m.header, check, "PoseStamped");
  return CheckedPose(m.pose, check, "PoseStamped", "pose");
}

RosSample<hullpipe_msgs_msg_dds__EyeViews_> MakeEyeViews(const EyeViewsSample& v, const std::string& frame_id) {
  RosSample<hullpipe_msgs_msg_dds__EyeViews_> s;
  s.strings.reserve(1);
  s.msg.header = Header(&s.strings, v.stamp_ns, frame_id);
  for (size_t k = 0; k < 2; ++k) {
    auto& e = s.msg.views[k];
    const Eigen::Vector3d& p = v.world_from_eye[k].translation;
    const Eigen::Vector4d q = XrOrientationOf(v.world_from_eye[k]);
    e.pose.position = {p.x(), p.y(), p.z()};
    e.pose.orientation = {q[0], q[1], q[2], q[3]};
    e.angle_left = float(v.fov[k].left), e.angle_right = float(v.fov[k].right);
    e.angle_up = float(v.fov[k].up), e.angle_down = float(v.fov[k].down);
  }
  return s;
}

EyeViewsSample EyeViewsFromRos2(const hullpipe_msgs_msg_dds__EyeViews_& m, const PoseCheck& check,
                                uint32_t tracker_id) {
  CheckHeader(m.header, check, "EyeViews");
  EyeViewsSample v;
  v.tracker_id = tracker_id;
  v.stamp_ns = NanosecondsOf(m.header.stamp);
  for (size_t k = 0; k < 2; ++k) {
    const auto& e = m.views[k];
    const std::string field = "views[" + std::to_string(k) + "]";
    // Checked as a tracker's pose; its axes are OpenXR's, turned to OpenCV's.
    const Rigid3d world_from_view = CheckedPose(e.pose, check, "EyeViews", field + ".pose");
    v.world_from_eye[k] = EyePoseFromXr(world_from_view.translation,
                                        Eigen::Vector4d(e.pose.orientation.x, e.pose.orientation.y,
                                                        e.pose.orientation.z, e.pose.orientation.w));
    try {
      v.fov[k] = EyeFov{e.angle_left, e.angle_right, e.angle_up, e.angle_down};
      v.fov[k].Check();
    } catch (const std::invalid_argument& err) {
      throw dds::MessageError("EyeViews: " + field + " field of view (angle_left/right/up/down): " + err.what());
    }
  }
  return v;
}

Rigid3d HeadFromTransform(const geometry_msgs_msg_dds__TransformStamped_& t, const PoseCheck& check) {
  geometry_msgs_msg_dds__PoseStamped_ pose{};
  pose.header = t.header;
  pose.pose.position = {t.transform.translation.x, t.transform.translation.y, t.transform.translation.z};
  pose.pose.orientation = t.transform.rotation;
  return HeadFromPoseStamped(pose, check);
}

}  // namespace hullpipe::ros2
