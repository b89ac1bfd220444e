#include "hullpipe/foxglove/channels.h"

#include <cmath>
#include <cstdlib>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/node_stats_convert.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/reconstruction/tile_set.h"

namespace hullpipe::foxglove {
namespace {

using nlohmann::json;

// JSON Schemas of the fields written below, under Foxglove's schema names (its
// panels pick a message's kind by the name; bytes are base64 strings).
constexpr const char* kTime =
    R"({"type":"object","properties":{"sec":{"type":"integer","minimum":0},"nsec":{"type":"integer","minimum":0,"maximum":999999999}}})";

std::string Schema(const std::string& title, const std::string& properties) {
  return R"({"title":")" + title + R"(","type":"object","properties":{)" + properties + "}}";
}

const std::string kVec3 =
    R"({"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"}}})";
const std::string kQuat =
    R"({"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"},"w":{"type":"number"}}})";
const std::string kColor =
    R"({"type":"object","properties":{"r":{"type":"number"},"g":{"type":"number"},"b":{"type":"number"},"a":{"type":"number"}}})";
const std::string kPose = R"({"type":"object","properties":{"position":)" + kVec3 + R"(,"orientation":)" + kQuat + "}}";

const std::string kCompressedImage = Schema(
    "foxglove.CompressedImage",
    std::string(R"("timestamp":)") + kTime +
        R"(,"frame_id":{"type":"string"},"data":{"type":"string","contentEncoding":"base64"},"format":{"type":"string"})");
const std::string kCameraCalibration = Schema(
    "foxglove.CameraCalibration",
    std::string(R"("timestamp":)") + kTime +
        R"(,"frame_id":{"type":"string"},"width":{"type":"integer"},"height":{"type":"integer"},"distortion_model":{"type":"string"},"D":{"type":"array","items":{"type":"number"}},"K":{"type":"array","items":{"type":"number"}},"R":{"type":"array","items":{"type":"number"}},"P":{"type":"array","items":{"type":"number"}})");
const std::string kFrameTransforms = Schema(
    "foxglove.FrameTransforms",
    R"("transforms":{"type":"array","items":{"type":"object","properties":{"timestamp":)" + std::string(kTime) +
        R"(,"parent_frame_id":{"type":"string"},"child_frame_id":{"type":"string"},"translation":)" + kVec3 +
        R"(,"rotation":)" + kQuat + "}}}");
const std::string kSceneUpdate = Schema(
    "foxglove.SceneUpdate",
    R"("deletions":{"type":"array","items":{"type":"object"}},"entities":{"type":"array","items":{"type":"object","properties":{"timestamp":)" +
        std::string(kTime) + R"(,"frame_id":{"type":"string"},"id":{"type":"string"},"lifetime":)" + kTime +
        R"(,"frame_locked":{"type":"boolean"},"spheres":{"type":"array","items":{"type":"object","properties":{"pose":)" +
        kPose + R"(,"size":)" + kVec3 + R"(,"color":)" + kColor +
        R"(}}},"triangles":{"type":"array","items":{"type":"object","properties":{"pose":)" + kPose +
        R"(,"points":{"type":"array","items":)" + kVec3 + R"(},"color":)" + kColor +
        R"(,"colors":{"type":"array","items":)" + kColor +
        R"(},"indices":{"type":"array","items":{"type":"integer","minimum":0}}}}}}}})");
const std::string kPointCloud = Schema(
    "foxglove.PointCloud",
    std::string(R"("timestamp":)") + kTime + R"(,"frame_id":{"type":"string"},"pose":)" + kPose +
        R"(,"point_stride":{"type":"integer"},"fields":{"type":"array","items":{"type":"object","properties":{"name":{"type":"string"},"offset":{"type":"integer"},"type":{"type":"integer"}}}},"data":{"type":"string","contentEncoding":"base64"})");
const std::string kNodeStatsPlot = Schema(
    "hullpipe.NodeStatsPlot",
    std::string(R"("timestamp":)") + kTime +
        R"(,"node":{"type":"string"},"fps":{"type":"number"},"latency_ms_p50":{"type":"number"},"latency_ms_p95":{"type":"number"},"frames_in":{"type":"integer"},"frames_out":{"type":"integer"},"dropped":{"type":"integer"},"rejected":{"type":"integer"})");

}  // namespace

const std::string& SchemaText(const std::string& name) {
  static const std::map<std::string, const std::string*> k = {
      {"foxglove.CompressedImage", &kCompressedImage}, {"foxglove.CameraCalibration", &kCameraCalibration},
      {"foxglove.FrameTransforms", &kFrameTransforms}, {"foxglove.SceneUpdate", &kSceneUpdate},
      {"foxglove.PointCloud", &kPointCloud},           {"hullpipe.NodeStatsPlot", &kNodeStatsPlot}};
  return *k.at(name);
}

namespace {

ChannelSpec Spec(const std::string& topic, const std::string& schema_name) {
  return {topic, schema_name, SchemaText(schema_name)};
}

json Time(int64_t ns) {
  if (ns < 0) ns = 0;
  return {{"sec", ns / 1'000'000'000}, {"nsec", ns % 1'000'000'000}};
}

std::string Base64(const uint8_t* in, size_t n) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((n + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < n; i += 3) {
    const uint32_t v = uint32_t(in[i]) << 16 | uint32_t(in[i + 1]) << 8 | in[i + 2];
    for (int s : {18, 12, 6, 0}) out += k[(v >> s) & 63];
  }
  if (i + 1 == n) {
    const uint32_t v = uint32_t(in[i]) << 16;
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == n) {
    const uint32_t v = uint32_t(in[i]) << 16 | uint32_t(in[i + 1]) << 8;
    for (int s : {18, 12, 6}) out += k[(v >> s) & 63];
    out += '=';
  }
  return out;
}

std::string Cam(uint32_t id) { return "cam" + std::to_string(id); }

json Rgba(double r, double g, double b) { return {{"r", r}, {"g", g}, {"b", b}, {"a", 1.0}}; }
json Color(bool red) { return red ? Rgba(1.0, 0.1, 0.1) : Rgba(0.2, 0.5, 1.0); }
json Bgr(const cv::Vec3b& c) { return Rgba(c[2] / 255.0, c[1] / 255.0, c[0] / 255.0); }

json Vec(double x, double y, double z) { return {{"x", x}, {"y", y}, {"z", z}}; }

json Pose(const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  return {{"position", Vec(p.x(), p.y(), p.z())},
          {"orientation", {{"x", q.x()}, {"y", q.y()}, {"z", q.z()}, {"w", q.w()}}}};
}

json Sphere(const Eigen::Vector3d& p, double diameter, json color) {
  return {{"pose", Pose(p, Eigen::Quaterniond::Identity())},
          {"size", Vec(diameter, diameter, diameter)},
          {"color", std::move(color)}};
}

// A triangle list in `pose`'s frame: points, indices (3 per triangle), one colour.
json Triangles(const Eigen::Vector3d& p, const Eigen::Quaterniond& q, json points, json indices, json color) {
  return {{"pose", Pose(p, q)},
          {"points", std::move(points)},
          {"color", std::move(color)},
          {"colors", json::array()},
          {"indices", std::move(indices)}};
}

// A scene entity (every primitive list present, as the schema has them).
json Entity(int64_t stamp_ns, const std::string& id, json spheres, json triangles = json::array()) {
  return {{"timestamp", Time(stamp_ns)}, {"frame_id", "world"}, {"id", id},     {"lifetime", Time(0)},
          {"frame_locked", false},       {"metadata", json::array()}, {"arrows", json::array()},
          {"cubes", json::array()},      {"spheres", std::move(spheres)}, {"cylinders", json::array()},
          {"lines", json::array()},      {"triangles", std::move(triangles)}, {"texts", json::array()},
          {"models", json::array()}};
}

json Scene(json entity) { return {{"deletions", json::array()}, {"entities", json::array({std::move(entity)})}}; }

std::string Text(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

// Bounds (the class comment).
constexpr size_t kMaxViews = 256;
constexpr size_t kMaxParts = 4096;
constexpr size_t kMaxPointSpheres = 4096;

// A model part's geometry, ready to send (body frame), and what was last sent.
struct PartGeometry {
  json points, indices;
  cv::Vec3b colour;
  bool sent = false;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Vector4d orientation{1, 0, 0, 0};
  uint8_t contact = 0;
};

}  // namespace

std::vector<ChannelSpec> FixedChannels() {
  std::vector<ChannelSpec> c = {Spec("/foxglove/tf", "foxglove.FrameTransforms")};
  for (const ViewEye eye : {ViewEye::kMono, ViewEye::kLeft, ViewEye::kRight}) {
    c.push_back(Spec(ForEye("/foxglove/hull_view", eye, '/'), "foxglove.CompressedImage"));
    c.push_back(Spec(ForEye("/foxglove/composited", eye, '/'), "foxglove.CompressedImage"));
  }
  for (const auto& spec : {Spec("/foxglove/hull_points", "foxglove.PointCloud"),
                           Spec("/foxglove/scene", "foxglove.SceneUpdate"),
                           Spec("/foxglove/node_stats", "hullpipe.NodeStatsPlot")})
    c.push_back(spec);
  return c;
}

std::vector<ChannelSpec> CameraChannels(uint32_t camera_id) {
  const std::string base = "/foxglove/" + Cam(camera_id);
  return {Spec(base + "/image", "foxglove.CompressedImage"),
          Spec(base + "/object_pixel_map", "foxglove.CompressedImage"),
          Spec(base + "/calibration", "foxglove.CameraCalibration")};
}

int64_t CameraOfTopic(const std::string& topic) {
  const std::string prefix = "/foxglove/cam";
  if (topic.compare(0, prefix.size(), prefix) != 0) return -1;
  const size_t slash = topic.find('/', prefix.size());
  if (slash == std::string::npos || slash == prefix.size() || slash - prefix.size() > 10) return -1;
  const std::string digits = topic.substr(prefix.size(), slash - prefix.size());
  if (digits.find_first_not_of("0123456789") != std::string::npos) return -1;
  const int64_t id = std::strtoll(digits.c_str(), nullptr, 10);
  if (id > int64_t(UINT32_MAX) || std::to_string(id) != digits) return -1;
  for (const auto& c : CameraChannels(uint32_t(id)))
    if (c.topic == topic) return id;
  return -1;
}

std::vector<std::string> SourceTypes(const std::string& topic) {
  const auto ends = [&](const std::string& s) {
    return topic.size() >= s.size() && topic.compare(topic.size() - s.size(), s.size(), s) == 0;
  };
  if (CameraOfTopic(topic) >= 0) {
    if (ends("/image")) return {"hullpipe::msg::CameraImage"};
    if (ends("/object_pixel_map")) return {"hullpipe::msg::ObjectPixelMap"};
    return {"hullpipe::msg::CameraInfo"};
  }
  if (topic == "/foxglove/tf") return {"hullpipe::msg::CameraInfo"};
  for (const ViewEye eye : {ViewEye::kMono, ViewEye::kLeft, ViewEye::kRight}) {
    if (topic == ForEye("/foxglove/composited", eye, '/')) return {"hullpipe::msg::CompositedView"};
    if (topic == ForEye("/foxglove/hull_view", eye, '/')) return {"hullpipe::msg::HullView", "hullpipe::msg::ViewPose"};
  }
  if (topic == "/foxglove/hull_points") return {"hullpipe::msg::HullView", "hullpipe::msg::ViewPose"};
  if (topic == "/foxglove/scene")
    return {"hullpipe::msg::VirtualObjectState", "hullpipe::msg::CollisionReport", "hullpipe::msg::VirtualMesh",
            "hullpipe::msg::ModelPart", "hullpipe::msg::ModelState"};
  if (topic == "/foxglove/node_stats") return {"hullpipe::msg::NodeStats"};
  return {};
}

struct Deriver::Impl {
  const dds::Participant& participant;
  Sink sink;
  Wanted wanted;
  std::map<std::string, std::unique_ptr<dds::CdrWriter>> decoders;  // by type name
  std::map<uint64_t, std::pair<NovelView, ViewEye>> views;          // recent ViewPoses by pose_seq
  TileSet tiles;                                                     // HullView tiles by pose
  std::map<uint32_t, PartGeometry> parts;                            // by object id
  dds::RegionBounds regions;  // the cameras' calibrated sizes: what bounds a region's whole image

  bool Want(const std::string& topic) const { return !wanted || wanted(topic); }

  void Send(const std::string& topic, const std::string& schema_name, int64_t stamp_ns, const json& j,
            std::string latch_key = {}) {
    sink(Message{topic, schema_name, stamp_ns, std::move(latch_key), Text(j)});
  }

  void Compressed(const std::string& topic, int64_t stamp_ns, const std::string& frame, const uint8_t* bytes,
                  size_t n, const char* format) {
    Send(topic, "foxglove.CompressedImage", stamp_ns,
         {{"timestamp", Time(stamp_ns)}, {"frame_id", frame}, {"data", Base64(bytes, n)}, {"format", format}});
  }
  void Encode(const std::string& topic, int64_t stamp_ns, const std::string& frame, const cv::Mat& image,
              const char* format) {
    if (!Want(topic) || image.empty()) return;
    std::vector<uint8_t> bytes;
    if (!cv::imencode(std::string(".") + (std::string(format) == "jpeg" ? "jpg" : format), image, bytes)) return;
    Compressed(topic, stamp_ns, frame, bytes.data(), bytes.size(), format);
  }

  const dds::CdrWriter& Decoder(const std::string& type_name) {
    auto& d = decoders[type_name];
    if (!d) {
      const dds::KnownType* kt = dds::FindKnownType(type_name);
      if (!kt) throw std::invalid_argument("not a hullpipe type: " + type_name);
      d = std::make_unique<dds::CdrWriter>(participant, *kt, kt->qos, dds::CdrWriter::Scope::kDecodeOnly);
    }
    return *d;
  }

  // Decodes `cdr` as T and calls f(m); false if it does not decode.
  template <typename T, typename F>
  bool With(const std::string& type_name, const std::vector<uint8_t>& cdr, F&& f) {
    return Decoder(type_name).template DecodeWith<T>(cdr, std::forward<F>(f));
  }
};

Deriver::Deriver(const dds::Participant& participant, Sink sink, Wanted wanted)
    : impl_(new Impl{participant, std::move(sink), std::move(wanted), {}, {}, {}, {}}) {}

Deriver::~Deriver() = default;

bool Deriver::Add(const std::string& type, const std::vector<uint8_t>& cdr, int64_t arrival_ns) {
  Impl& d = *impl_;
  try {
    if (type == "hullpipe::msg::CameraInfo")
      return d.With<hullpipe_msg_CameraInfo>(type, cdr, [&](const auto& m) {
        const Camera cam = dds::CameraFromMsg(m);  // validated as the nodes validate it
        d.regions.Calibrated(m.camera_id, cam.width, cam.height);
        Calibration(arrival_ns, m);
      });
    if (type == "hullpipe::msg::CameraImage")
      return d.With<hullpipe_msg_CameraImage>(type, cdr, [&](const auto& m) {
        if (!d.Want("/foxglove/" + Cam(m.camera_id) + "/image")) return;
        d.regions.CheckRegion(m);
        if (m.encoding == hullpipe_msg_IMAGE_ENCODING_JPEG && !dds::ImageHasRegion(m)) {
          // Passed through: only a JPEG of the stated size (as ImageFromMsg checks).
          // A region is shown in its whole image (black around it), encoded again.
          dds::CheckJpegOfSize("CameraImage: ", m.data._buffer, m.data._length, m.width, m.height);
          d.Compressed("/foxglove/" + Cam(m.camera_id) + "/image", m.capture_time_ns, Cam(m.camera_id),
                       m.data._buffer, m.data._length, "jpeg");
          return;
        }
        Image(m.capture_time_ns, m.camera_id, dds::ImageFromMsg(m));
      });
    if (type == "hullpipe::msg::ObjectPixelMap")
      return d.With<hullpipe_msg_ObjectPixelMap>(type, cdr, [&](const auto& m) {
        if (d.Want("/foxglove/" + Cam(m.camera_id) + "/object_pixel_map"))
          Map(m.capture_time_ns, m.camera_id, dds::MapFromMsg(m));
      });
    if (type == "hullpipe::msg::ViewPose")
      return d.With<hullpipe_msg_ViewPose>(type, cdr, [&](const auto& m) {
        d.views[m.pose_seq] = {dds::ViewFromMsg(m), ViewEye(m.eye)};  // the eye checked by ViewFromMsg
        while (d.views.size() > kMaxViews) d.views.erase(d.views.begin());
      });
    if (type == "hullpipe::msg::HullView")
      return d.With<hullpipe_msg_HullView>(type, cdr, [&](const auto& m) {
        const uint64_t pose = m.pose_seq;
        const auto pose_view = d.views.find(pose);
        // The eye of its ViewPose; a tile whose pose was not seen is shown as the one view.
        const ViewEye eye = pose_view == d.views.end() ? ViewEye::kMono : pose_view->second.second;
        if (!d.Want(ForEye("/foxglove/hull_view", eye, '/')) && !d.Want("/foxglove/hull_points")) return;
        const auto view = d.tiles.Add(dds::TileFromMsg(m));
        if (!view) return;
        // One cloud per frameset: a stereo pair's right eye sees the same hull
        // from an IPD aside.
        if (pose_view != d.views.end() && eye != ViewEye::kRight)
          HullPoints(m.capture_time_ns, pose_view->second.first, view->depth);
        HullView(m.capture_time_ns, view->colour, eye);
      });
    if (type == "hullpipe::msg::CompositedView")
      return d.With<hullpipe_msg_CompositedView>(type, cdr, [&](const auto& m) {
        // render_node's JPEG, passed through once its header is checked.
        dds::CheckCompositedViewMsg(m);
        const ViewEye eye = ViewEye(m.eye);  // checked just now
        const std::string topic = ForEye("/foxglove/composited", eye, '/');
        if (d.Want(topic))
          d.Compressed(topic, m.capture_time_ns, ForEye("view", eye, '_'), m.data._buffer, m.data._length, "jpeg");
      });
    if (type == "hullpipe::msg::VirtualObjectState")
      return d.With<hullpipe_msg_VirtualObjectState>(type, cdr, [&](const auto& m) {
        const VirtualObjectSample o = dds::VirtualObjectFromMsg(m);
        Object(o.capture_time_ns, o);
      });
    if (type == "hullpipe::msg::CollisionReport")
      return d.With<hullpipe_msg_CollisionReport>(type, cdr,
                                                   [&](const auto& m) { Collision(m.capture_time_ns, m); });
    if (type == "hullpipe::msg::VirtualMesh")
      return d.With<hullpipe_msg_VirtualMesh>(type, cdr, [&](const auto& m) {
        if (!d.Want("/foxglove/scene")) return;
        const VirtualMeshSample mesh = dds::VirtualMeshFromMsg(m);
        Mesh(mesh.capture_time_ns, mesh);
      });
    if (type == "hullpipe::msg::ModelPart")
      return d.With<hullpipe_msg_ModelPart>(type, cdr, [&](const auto& m) { Part(dds::ModelPartFromMsg(m)); });
    if (type == "hullpipe::msg::ModelState")
      return d.With<hullpipe_msg_ModelState>(type, cdr, [&](const auto& m) {
        const ModelStateSample s = dds::ModelStateFromMsg(m);
        Model(s.capture_time_ns, s);
      });
    if (type == "hullpipe::msg::NodeStats")
      return d.With<hullpipe_msg_NodeStats>(type, cdr,
                                            [&](const auto& m) { Stats(arrival_ns, dds::NodeStatsFromMsg(m)); });
    // Other types (commands, head poses) have no viewable channel; the sample
    // is still a valid one of its type.
    if (const dds::KnownType* kt = dds::FindKnownType(type)) {
      std::vector<uint8_t> sample(kt->descriptor->m_size);
      const bool ok = d.Decoder(type).Decode(cdr, sample.data());
      if (ok) dds_sample_free(sample.data(), kt->descriptor, DDS_FREE_CONTENTS);
      return ok;
    }
    return false;
  } catch (const std::exception&) {  // MessageError and friends: a sample the nodes would refuse
    return false;
  }
}

void Deriver::Calibration(int64_t stamp_ns, const hullpipe_msg_CameraInfo& m) {
  Impl& d = *impl_;
  // Foxglove (as ROS) puts pixel centres at integers, hullpipe at +0.5.
  std::vector<double> K(m.K, m.K + 9);
  K[2] -= kOpenCvToHullpipePixelOffset;
  K[5] -= kOpenCvToHullpipePixelOffset;
  const std::vector<double> P = {K[0], K[1], K[2], 0, K[3], K[4], K[5], 0, K[6], K[7], K[8], 0};
  d.Send("/foxglove/" + Cam(m.camera_id) + "/calibration", "foxglove.CameraCalibration", stamp_ns,
         {{"timestamp", Time(stamp_ns)},
          {"frame_id", Cam(m.camera_id)},
          {"width", m.width},
          {"height", m.height},
          {"distortion_model", "plumb_bob"},
          {"D", std::vector<double>(m.distortion, m.distortion + 5)},
          {"K", K},
          {"R", {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0}},
          {"P", P}},
         Cam(m.camera_id));
  // world_from_cam: the camera's pose in the world (x_world = R^T (x_cam - t)).
  Eigen::Matrix3d R;
  for (int i = 0; i < 9; ++i) R(i / 3, i % 3) = m.cam_from_world_rotation[i];
  const Eigen::Vector3d t(m.cam_from_world_translation[0], m.cam_from_world_translation[1],
                          m.cam_from_world_translation[2]);
  const Eigen::Vector3d centre = -R.transpose() * t;
  const Eigen::Quaterniond q(R.transpose());
  d.Send("/foxglove/tf", "foxglove.FrameTransforms", stamp_ns,
         {{"transforms",
           {{{"timestamp", Time(stamp_ns)},
             {"parent_frame_id", "world"},
             {"child_frame_id", Cam(m.camera_id)},
             {"translation", Vec(centre.x(), centre.y(), centre.z())},
             {"rotation", {{"x", q.x()}, {"y", q.y()}, {"z", q.z()}, {"w", q.w()}}}}}}},
         Cam(m.camera_id));
}

void Deriver::Image(int64_t stamp_ns, uint32_t camera_id, const cv::Mat& bgr) {
  impl_->Encode("/foxglove/" + Cam(camera_id) + "/image", stamp_ns, Cam(camera_id), bgr, "jpeg");
}

void Deriver::Map(int64_t stamp_ns, uint32_t camera_id, const cv::Mat& map) {
  impl_->Encode("/foxglove/" + Cam(camera_id) + "/object_pixel_map", stamp_ns, Cam(camera_id), map, "png");
}

void Deriver::HullView(int64_t stamp_ns, const cv::Mat& bgr, ViewEye eye) {
  impl_->Encode(ForEye("/foxglove/hull_view", eye, '/'), stamp_ns, ForEye("view", eye, '_'), bgr, "jpeg");
}

void Deriver::HullPoints(int64_t stamp_ns, const NovelView& view, const cv::Mat& depth) {
  if (!impl_->Want("/foxglove/hull_points")) return;
  // x, y, z and depth as little-endian float32 (Foxglove's NumericType 7).
  constexpr int kStep = 4;
  std::vector<uint8_t> data;
  for (int v = 0; v < depth.rows; v += kStep)
    for (int u = 0; u < depth.cols; u += kStep) {
      const float z = depth.at<float>(v, u);
      if (!(z > 0) || !std::isfinite(z)) continue;
      // Pixel centres at +0.5 (geometry/conventions.h).
      const Eigen::Vector3d p = view.EyeRay(u + 0.5, v + 0.5) * double(z);
      const float xyzd[4] = {float(p.x()), float(p.y()), float(p.z()), z};
      const auto* b = reinterpret_cast<const uint8_t*>(xyzd);
      data.insert(data.end(), b, b + sizeof xyzd);
    }
  json fields = json::array();
  int offset = 0;
  for (const char* name : {"x", "y", "z", "depth"}) {
    fields.push_back({{"name", name}, {"offset", offset}, {"type", 7}});
    offset += 4;
  }
  impl_->Send("/foxglove/hull_points", "foxglove.PointCloud", stamp_ns,
              {{"timestamp", Time(stamp_ns)},
               {"frame_id", "world"},
               {"pose", Pose(view.world_from_eye.translation, Eigen::Quaterniond(view.world_from_eye.rotation))},
               {"point_stride", 16},
               {"fields", fields},
               {"data", Base64(data.data(), data.size())}});
}

void Deriver::Object(int64_t stamp_ns, const VirtualObjectSample& o) {
  if (!impl_->Want("/foxglove/scene")) return;
  if (o.shape == VirtualObjectSample::Shape::kBox) {
    const json cube = {{"pose", Pose(o.position, o.orientation)},
                       {"size", Vec(2 * o.half_extents.x(), 2 * o.half_extents.y(), 2 * o.half_extents.z())},
                       {"color", Color(o.colliding)}};
    json entity = Entity(stamp_ns, "box" + std::to_string(o.object_id), json::array());
    entity["cubes"] = json::array({cube});
    impl_->Send("/foxglove/scene", "foxglove.SceneUpdate", stamp_ns, Scene(std::move(entity)));
    return;
  }
  impl_->Send("/foxglove/scene", "foxglove.SceneUpdate", stamp_ns,
              Scene(Entity(stamp_ns, "ball" + std::to_string(o.object_id),
                           json::array({Sphere(o.position, 2 * o.radius, Color(o.colliding))}))));
}

void Deriver::Collision(int64_t stamp_ns, const hullpipe_msg_CollisionReport& m) {
  if (!impl_->Want("/foxglove/scene")) return;
  json spheres = json::array();
  for (uint32_t i = 0; i < m.collision_points._length; ++i) {
    const auto& p = m.collision_points._buffer[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    spheres.push_back(Sphere(Eigen::Vector3d(p.x, p.y, p.z), 0.01, Color(true)));
  }
  impl_->Send("/foxglove/scene", "foxglove.SceneUpdate", stamp_ns,
              Scene(Entity(stamp_ns, "collision_points" + std::to_string(m.object_id), spheres)));
}

void Deriver::Mesh(int64_t stamp_ns, const VirtualMeshSample& mesh) {
  if (!impl_->Want("/foxglove/scene")) return;
  const auto& draw = mesh.draw;
  const std::string id = "mesh" + std::to_string(mesh.object_id);
  const auto colliding = [&](size_t i) { return i < draw.colliding.size() && draw.colliding[i] != 0; };
  if (draw.triangles.empty()) {  // a particle stream: its points as small spheres
    json spheres = json::array();
    for (size_t i = 0; i < draw.vertices.size() && i < kMaxPointSpheres; ++i)
      spheres.push_back(Sphere(draw.vertices[i], 2 * draw.point_radius, colliding(i) ? Color(true) : Bgr(draw.colour)));
    impl_->Send("/foxglove/scene", "foxglove.SceneUpdate", stamp_ns, Scene(Entity(stamp_ns, id, spheres)));
    return;
  }
  // World vertices; the clear and the colliding triangles as two lists.
  json points = json::array();
  for (const auto& v : draw.vertices) points.push_back(Vec(v.x(), v.y(), v.z()));
  json clear = json::array(), red = json::array();
  for (size_t i = 0; i < draw.triangles.size(); ++i)
    for (int k = 0; k < 3; ++k) (colliding(i) ? red : clear).push_back(draw.triangles[i][k]);
  json tris = json::array();
  const Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  const Eigen::Quaterniond identity = Eigen::Quaterniond::Identity();
  if (!clear.empty()) tris.push_back(Triangles(origin, identity, points, std::move(clear), Bgr(draw.colour)));
  if (!red.empty()) tris.push_back(Triangles(origin, identity, std::move(points), std::move(red), Color(true)));
  impl_->Send("/foxglove/scene", "foxglove.SceneUpdate", stamp_ns, Scene(Entity(stamp_ns, id, json::array(), tris)));
}

void Deriver::Part(const ModelPartSample& part) {
  Impl& d = *impl_;
  if (!d.parts.count(part.object_id) && d.parts.size() >= kMaxParts) return;
  PartGeometry g;
  g.points = json::array();
  for (const auto& v : part.vertices) g.points.push_back(Vec(v.x(), v.y(), v.z()));
  g.indices = json::array();
  for (const auto& t : part.triangles)
    for (int k = 0; k < 3; ++k) g.indices.push_back(t[k]);
  g.colour = part.colour;
  d.parts[part.object_id] = std::move(g);
}

void Deriver::Model(int64_t stamp_ns, const ModelStateSample& state) {
  Impl& d = *impl_;
  // Each part is sent when first seen and when its pose or contact changes
  // (a CAD model at rest is sent once, not every frameset); the latest of each
  // is latched for viewers that come later.
  for (size_t i = 0; i < state.parts.size(); ++i) {
    const uint64_t object_id = uint64_t(state.model_id) + i;
    if (object_id > UINT32_MAX) break;
    const auto it = d.parts.find(uint32_t(object_id));
    if (it == d.parts.end()) continue;  // its geometry has not come (yet)
    PartGeometry& g = it->second;
    const PartStateSample& p = state.parts[i];
    if (g.sent && g.contact == p.contact && (g.position - p.position).norm() < 1e-6 &&
        (g.orientation - p.orientation).norm() < 1e-9)
      continue;
    g.sent = true, g.contact = p.contact, g.position = p.position, g.orientation = p.orientation;
    const json colour = p.contact == kPartColliding ? Color(true)
                        : p.contact == kPartNear   ? Rgba(1.0, 0.65, 0.0)
                                                   : Bgr(g.colour);
    const Eigen::Quaterniond q(p.orientation[0], p.orientation[1], p.orientation[2], p.orientation[3]);
    const std::string id = "part" + std::to_string(object_id);
    d.Send("/foxglove/scene", "foxglove.SceneUpdate", stamp_ns,
           Scene(Entity(stamp_ns, id, json::array(),
                        json::array({Triangles(p.position, q, g.points, g.indices, colour)}))),
           id);
  }
}

void Deriver::Stats(int64_t stamp_ns, const NodeStatsSample& st) {
  if (!impl_->Want("/foxglove/node_stats")) return;
  impl_->Send("/foxglove/node_stats", "hullpipe.NodeStatsPlot", stamp_ns,
              {{"timestamp", Time(stamp_ns)},
               {"node", st.name},
               {"fps", st.fps},
               {"latency_ms_p50", st.latency_ms_p50},
               {"latency_ms_p95", st.latency_ms_p95},
               {"frames_in", st.frames_in},
               {"frames_out", st.frames_out},
               {"dropped", st.dropped},
               {"rejected", st.rejected}});
}

}  // namespace hullpipe::foxglove
