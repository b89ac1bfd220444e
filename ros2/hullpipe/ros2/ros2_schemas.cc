#include "hullpipe/ros2/ros2_schemas.h"

#include <algorithm>
#include <map>
#include <stdexcept>

#include "hullpipe/ros2/ros2_messages.h"
#include "hullpipe/ros2/ros2_topics.h"
#include "hullpipe_msgs_definitions.h"  // generated from ros2/hullpipe_msgs/msg

namespace hullpipe::ros2 {

namespace {

// Each type's own definition (ROS 2 Humble's fields, package-qualified types).
const std::map<std::string, std::string>& Definitions() {
  static const std::map<std::string, std::string> d = {
      {"builtin_interfaces/msg/Time", "int32 sec\nuint32 nanosec\n"},
      {"std_msgs/msg/Header", "builtin_interfaces/Time stamp\nstring frame_id\n"},
      {"geometry_msgs/msg/Vector3", "float64 x\nfloat64 y\nfloat64 z\n"},
      {"geometry_msgs/msg/Point", "float64 x\nfloat64 y\nfloat64 z\n"},
      {"geometry_msgs/msg/Quaternion", "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n"},
      {"geometry_msgs/msg/Pose", "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n"},
      {"geometry_msgs/msg/PoseStamped", "std_msgs/Header header\ngeometry_msgs/Pose pose\n"},
      {"geometry_msgs/msg/Transform", "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n"},
      {"geometry_msgs/msg/TransformStamped",
       "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n"},
      {"tf2_msgs/msg/TFMessage", "geometry_msgs/TransformStamped[] transforms\n"},
      {"sensor_msgs/msg/RegionOfInterest",
       "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n"},
      {"sensor_msgs/msg/CameraInfo",
       "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\nfloat64[] d\nfloat64[9] k\n"
       "float64[9] r\nfloat64[12] p\nuint32 binning_x\nuint32 binning_y\nsensor_msgs/RegionOfInterest roi\n"},
      {"sensor_msgs/msg/Image",
       "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\n"
       "uint8[] data\n"},
      {"sensor_msgs/msg/CompressedImage", "std_msgs/Header header\nstring format\nuint8[] data\n"},
      {"builtin_interfaces/msg/Duration", "int32 sec\nuint32 nanosec\n"},
      {"std_msgs/msg/ColorRGBA", "float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n"},
      {"sensor_msgs/msg/PointField",
       "uint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\nuint8 UINT32=6\n"
       "uint8 FLOAT32=7\nuint8 FLOAT64=8\nstring name\nuint32 offset\nuint8 datatype\nuint32 count\n"},
      {"sensor_msgs/msg/PointCloud2",
       "std_msgs/Header header\nuint32 height\nuint32 width\nsensor_msgs/PointField[] fields\nbool is_bigendian\n"
       "uint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n"},
      {"visualization_msgs/msg/UVCoordinate", "float32 u\nfloat32 v\n"},
      {"visualization_msgs/msg/MeshFile", "string filename\nuint8[] data\n"},
      {"visualization_msgs/msg/Marker",
       "int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\nint32 LINE_STRIP=4\nint32 LINE_LIST=5\n"
       "int32 CUBE_LIST=6\nint32 SPHERE_LIST=7\nint32 POINTS=8\nint32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\n"
       "int32 TRIANGLE_LIST=11\nint32 ADD=0\nint32 MODIFY=0\nint32 DELETE=2\nint32 DELETEALL=3\n"
       "std_msgs/Header header\nstring ns\nint32 id\nint32 type\nint32 action\ngeometry_msgs/Pose pose\n"
       "geometry_msgs/Vector3 scale\nstd_msgs/ColorRGBA color\nbuiltin_interfaces/Duration lifetime\n"
       "bool frame_locked\ngeometry_msgs/Point[] points\nstd_msgs/ColorRGBA[] colors\nstring texture_resource\n"
       "sensor_msgs/CompressedImage texture\nvisualization_msgs/UVCoordinate[] uv_coordinates\nstring text\n"
       "string mesh_resource\nvisualization_msgs/MeshFile mesh_file\nbool mesh_use_embedded_materials\n"},
      {"visualization_msgs/msg/MarkerArray", "visualization_msgs/Marker[] markers\n"},
      {"hullpipe_msgs/msg/CollisionReport", kCollisionReportMsg},
  };
  return d;
}

// The types `type` uses, depth first, each once. A definition's line is a
// field ("type name"), a constant ("type NAME=value"), a comment or blank.
void Uses(const std::string& type, std::vector<std::string>* out) {
  const std::string& text = Definitions().at(type);
  size_t at = 0;
  while (at < text.size()) {
    size_t end = text.find('\n', at);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(at, end - at);
    at = end + 1;
    line.resize(std::min(line.size(), line.find('#')));
    const size_t start = line.find_first_not_of(" \t");
    if (start == std::string::npos) continue;  // blank or a comment
    std::string field_type = line.substr(start, line.find_first_of(" \t", start) - start);
    const size_t bracket = field_type.find('[');
    if (bracket != std::string::npos) field_type.resize(bracket);
    const size_t slash = field_type.find('/');
    if (slash == std::string::npos) continue;  // a primitive
    const std::string full = field_type.substr(0, slash) + "/msg" + field_type.substr(slash);
    bool seen = false;
    for (const auto& s : *out) seen |= s == full;
    if (seen) continue;
    out->push_back(full);
    Uses(full, out);
  }
}

template <typename Msg, typename Probe>
dds::KnownType Known(const dds_topic_descriptor_t* desc, Probe probe) {
  dds::KnownType k;
  k.descriptor = desc;
  k.type_name = desc->m_typename;
  k.topic_name = "hullpipe_ros2_probe/" + std::string(desc->m_typename);
  for (char& c : k.topic_name)
    if (c == ':') c = '_';
  k.qos = kDefaultQos;
  k.write_probe = [probe](dds_entity_t writer) {
    auto sample = probe();
    dds::Check(dds_write(writer, &sample.msg), "dds_write (sertype probe)");
  };
  return k;
}

}  // namespace

const std::vector<std::string>& Ros2TypeNames() {
  static const std::vector<std::string> names = {"sensor_msgs/msg/CameraInfo", "sensor_msgs/msg/Image",
                                                  "sensor_msgs/msg/CompressedImage", "tf2_msgs/msg/TFMessage",
                                                  "geometry_msgs/msg/PoseStamped", "sensor_msgs/msg/PointCloud2",
                                                  "visualization_msgs/msg/MarkerArray",
                                                  "hullpipe_msgs/msg/CollisionReport"};
  return names;
}

std::string Ros2MsgSchema(const std::string& type) {
  if (!Definitions().count(type)) throw std::invalid_argument("no ROS 2 definition of " + type);
  std::string s = Definitions().at(type);
  std::vector<std::string> uses;
  Uses(type, &uses);
  for (const std::string& u : uses) {
    const size_t msg = u.find("/msg/");
    s += std::string(80, '=') + "\nMSG: " + u.substr(0, msg) + "/" + u.substr(msg + 5) + "\n" + Definitions().at(u);
  }
  return s;
}

std::string OfferedQosProfiles(const dds::QosSpec& q) {
  const std::string infinite = "\n    sec: 2147483647\n    nsec: 4294967295";
  return "- history: 1\n  depth: " + std::to_string(q.depth) + "\n  reliability: " + (q.reliable ? "1" : "2") +
         "\n  durability: " + (q.transient_local ? "1" : "2") + "\n  deadline:" + infinite + "\n  lifespan:" +
         infinite + "\n  liveliness: 1\n  liveliness_lease_duration:" + infinite +
         "\n  avoid_ros_namespace_conventions: false\n";
}

dds::KnownType Ros2KnownType(const std::string& type) {
  if (type == "sensor_msgs/msg/CameraInfo")
    return Known<sensor_msgs_msg_dds__CameraInfo_>(&sensor_msgs_msg_dds__CameraInfo__desc,
                                                   [] { return MakeCameraInfo(Camera{}, 0); });
  if (type == "sensor_msgs/msg/Image")
    return Known<sensor_msgs_msg_dds__Image_>(&sensor_msgs_msg_dds__Image__desc, [] {
      return MakeMono8Image(cv::Mat(1, 1, CV_8UC1, cv::Scalar(0)), 0, "");
    });
  if (type == "sensor_msgs/msg/CompressedImage")
    return Known<sensor_msgs_msg_dds__CompressedImage_>(&sensor_msgs_msg_dds__CompressedImage__desc,
                                                        [] { return MakeCompressedImage({0}, 0, ""); });
  if (type == "tf2_msgs/msg/TFMessage")
    return Known<tf2_msgs_msg_dds__TFMessage_>(&tf2_msgs_msg_dds__TFMessage__desc,
                                               [] { return MakeCameraTransforms({}, 0); });
  if (type == "geometry_msgs/msg/PoseStamped")
    return Known<geometry_msgs_msg_dds__PoseStamped_>(&geometry_msgs_msg_dds__PoseStamped__desc,
                                                      [] { return MakePoseStamped(Rigid3d{}, 0, ""); });
  if (type == "sensor_msgs/msg/PointCloud2")
    return Known<sensor_msgs_msg_dds__PointCloud2_>(&sensor_msgs_msg_dds__PointCloud2__desc, [] {
      return MakeHullPointCloud(NovelView::FromFov(1, 1, 1.0, Rigid3d{}), cv::Mat(1, 1, CV_32FC1, cv::Scalar(0)),
                                cv::Mat(1, 1, CV_8UC3, cv::Scalar(0, 0, 0)), 1, 0);
    });
  if (type == "visualization_msgs/msg/MarkerArray")
    return Known<visualization_msgs_msg_dds__MarkerArray_>(&visualization_msgs_msg_dds__MarkerArray__desc,
                                                           [] { return MakeContactMarker(0, {}, 0); });
  if (type == "hullpipe_msgs/msg/CollisionReport")
    return Known<hullpipe_msgs_msg_dds__CollisionReport_>(&hullpipe_msgs_msg_dds__CollisionReport__desc,
                                                          [] { return MakeCollisionReport(CollisionReportSample{}); });
  if (type == "hullpipe_msgs/msg/EyeViews")  // read by hullpipe_ros2, not written
    return Known<hullpipe_msgs_msg_dds__EyeViews_>(&hullpipe_msgs_msg_dds__EyeViews__desc,
                                                   [] { return MakeEyeViews(EyeViewsSample{}, ""); });
  throw std::invalid_argument("no ROS 2 type " + type);
}

}  // namespace hullpipe::ros2
