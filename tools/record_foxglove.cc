#include "record_foxglove.h"

#include <cmath>

#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>

#include "hullpipe/geometry/conventions.h"

namespace hullpipe::record {
namespace {

using nlohmann::json;

// JSON Schemas of the fields written below, under Foxglove's schema names (its
// panels pick a message's kind by the name; bytes are base64 strings).
constexpr const char* kTime =
    R"({"type":"object","properties":{"sec":{"type":"integer","minimum":0},"nsec":{"type":"integer","minimum":0,"maximum":999999999}}})";

std::string Schema(const std::string& title, const std::string& properties) {
  return R"({"title":")" + title + R"(","type":"object","properties":{)" + properties + "}}";
}

const std::string kCompressedImage = Schema(
    "foxglove.CompressedImage", std::string(R"("timestamp":)") + kTime +
                                    R"(,"frame_id":{"type":"string"},"data":{"type":"string","contentEncoding":"base64"},"format":{"type":"string"})");
const std::string kCameraCalibration = Schema(
    "foxglove.CameraCalibration",
    std::string(R"("timestamp":)") + kTime +
        R"(,"frame_id":{"type":"string"},"width":{"type":"integer"},"height":{"type":"integer"},"distortion_model":{"type":"string"},"D":{"type":"array","items":{"type":"number"}},"K":{"type":"array","items":{"type":"number"}},"R":{"type":"array","items":{"type":"number"}},"P":{"type":"array","items":{"type":"number"}})");
const std::string kVec3 = R"({"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"}}})";
const std::string kQuat =
    R"({"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"},"w":{"type":"number"}}})";
const std::string kFrameTransforms = Schema(
    "foxglove.FrameTransforms",
    R"("transforms":{"type":"array","items":{"type":"object","properties":{"timestamp":)" + std::string(kTime) +
        R"(,"parent_frame_id":{"type":"string"},"child_frame_id":{"type":"string"},"translation":)" + kVec3 +
        R"(,"rotation":)" + kQuat + "}}}");
const std::string kColor =
    R"({"type":"object","properties":{"r":{"type":"number"},"g":{"type":"number"},"b":{"type":"number"},"a":{"type":"number"}}})";
const std::string kSceneUpdate = Schema(
    "foxglove.SceneUpdate",
    R"("deletions":{"type":"array","items":{"type":"object"}},"entities":{"type":"array","items":{"type":"object","properties":{"timestamp":)" +
        std::string(kTime) +
        R"(,"frame_id":{"type":"string"},"id":{"type":"string"},"lifetime":)" + kTime +
        R"(,"frame_locked":{"type":"boolean"},"spheres":{"type":"array","items":{"type":"object","properties":{"pose":{"type":"object","properties":{"position":)" +
        kVec3 + R"(,"orientation":)" + kQuat + R"(}},"size":)" + kVec3 + R"(,"color":)" + kColor + "}}}}}}");
const std::string kPointCloud = Schema(
    "foxglove.PointCloud",
    std::string(R"("timestamp":)") + kTime +
        R"(,"frame_id":{"type":"string"},"pose":{"type":"object","properties":{"position":)" + kVec3 +
        R"(,"orientation":)" + kQuat +
        R"(}},"point_stride":{"type":"integer"},"fields":{"type":"array","items":{"type":"object","properties":{"name":{"type":"string"},"offset":{"type":"integer"},"type":{"type":"integer"}}}},"data":{"type":"string","contentEncoding":"base64"})");
const std::string kNodeStatsPlot = Schema(
    "hullpipe.NodeStatsPlot",
    std::string(R"("timestamp":)") + kTime +
        R"(,"node":{"type":"string"},"fps":{"type":"number"},"latency_ms_p50":{"type":"number"},"latency_ms_p95":{"type":"number"},"frames_in":{"type":"integer"},"frames_out":{"type":"integer"},"dropped":{"type":"integer"},"rejected":{"type":"integer"})");

json Time(int64_t ns) {
  if (ns < 0) ns = 0;
  return {{"sec", ns / 1'000'000'000}, {"nsec", ns % 1'000'000'000}};
}

std::string Base64(const std::vector<uint8_t>& in) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const uint32_t v = uint32_t(in[i]) << 16 | uint32_t(in[i + 1]) << 8 | in[i + 2];
    for (int s : {18, 12, 6, 0}) out += k[(v >> s) & 63];
  }
  if (i + 1 == in.size()) {
    const uint32_t v = uint32_t(in[i]) << 16;
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == in.size()) {
    const uint32_t v = uint32_t(in[i]) << 16 | uint32_t(in[i + 1]) << 8;
    for (int s : {18, 12, 6}) out += k[(v >> s) & 63];
    out += '=';
  }
  return out;
}

std::string Cam(uint32_t id) { return "cam" + std::to_string(id); }

json Color(bool red) {
  return red ? json{{"r", 1.0}, {"g", 0.1}, {"b", 0.1}, {"a", 1.0}} : json{{"r", 0.2}, {"g", 0.5}, {"b", 1.0}, {"a", 1.0}};
}

json Sphere(const Eigen::Vector3d& p, double diameter, bool red) {
  return {{"pose", {{"position", {{"x", p.x()}, {"y", p.y()}, {"z", p.z()}}},
                    {"orientation", {{"x", 0.0}, {"y", 0.0}, {"z", 0.0}, {"w", 1.0}}}}},
          {"size", {{"x", diameter}, {"y", diameter}, {"z", diameter}}},
          {"color", Color(red)}};
}

// A scene entity of spheres (every primitive list present, as the schema has them).
json Entity(int64_t stamp_ns, const std::string& id, json spheres) {
  return {{"timestamp", Time(stamp_ns)}, {"frame_id", "world"}, {"id", id},     {"lifetime", Time(0)},
          {"frame_locked", false},       {"metadata", json::array()}, {"arrows", json::array()},
          {"cubes", json::array()},      {"spheres", std::move(spheres)}, {"cylinders", json::array()},
          {"lines", json::array()},      {"triangles", json::array()},    {"texts", json::array()},
          {"models", json::array()}};
}

WriterOptions McapZstd() {
  WriterOptions o;
  o.storage = Storage::kMcap;
  o.compression = Compression::kZstd;
  return o;
}

}  // namespace

FoxgloveExport::FoxgloveExport(const std::string& path) : path_(path), w_(path, McapZstd()) {
  w_.SetMeta("foxglove_channels", "derived by hullpipe_record export --foxglove (docs/recording.md)");
}

void FoxgloveExport::Raw(const TopicInfo& topic, const Sample& sample) {
  auto it = ids_.find(topic.name);
  if (it == ids_.end()) it = ids_.emplace(topic.name, w_.AddTopic(topic)).first;
  Sample s = sample;
  s.topic_id = it->second;
  log_ns_ = s.arrival_ns;
  w_.Append(s);
  if (++appended_ % 64 == 0) w_.Commit();
}

void FoxgloveExport::Json(const std::string& topic, const std::string& schema, const char* schema_json,
                          int64_t stamp_ns, const json& message) {
  auto it = ids_.find(topic);
  if (it == ids_.end()) {
    TopicInfo t;
    t.name = topic;
    t.type = schema;
    t.type_description = schema_json;
    t.schema_encoding = "jsonschema";
    t.message_encoding = "json";
    it = ids_.emplace(topic, w_.AddTopic(t)).first;
  }
  Sample s;
  s.topic_id = it->second;
  s.arrival_ns = log_ns_ >= 0 ? log_ns_ : stamp_ns;
  s.source_ns = stamp_ns;
  const std::string text = message.dump(-1, ' ', false, json::error_handler_t::replace);
  s.data.assign(text.begin(), text.end());
  w_.Append(s);
  ++counts_[topic];
  if (++appended_ % 64 == 0) w_.Commit();
}

void FoxgloveExport::Compressed(const std::string& topic, int64_t stamp_ns, const std::string& frame,
                                const cv::Mat& image, const char* format) {
  std::vector<uint8_t> bytes;
  if (!cv::imencode(std::string(".") + (std::string(format) == "jpeg" ? "jpg" : format), image, bytes)) return;
  Json(topic, "foxglove.CompressedImage", kCompressedImage.c_str(), stamp_ns,
       {{"timestamp", Time(stamp_ns)}, {"frame_id", frame}, {"data", Base64(bytes)}, {"format", format}});
}

void FoxgloveExport::Calibration(int64_t stamp_ns, const hullpipe_msg_CameraInfo& m) {
  // Foxglove (as ROS) puts pixel centres at integers, hullpipe at +0.5.
  std::vector<double> K(m.K, m.K + 9);
  K[2] -= kOpenCvToHullpipePixelOffset;
  K[5] -= kOpenCvToHullpipePixelOffset;
  const std::vector<double> P = {K[0], K[1], K[2], 0, K[3], K[4], K[5], 0, K[6], K[7], K[8], 0};
  Json("/foxglove/" + Cam(m.camera_id) + "/calibration", "foxglove.CameraCalibration", kCameraCalibration.c_str(),
       stamp_ns,
       {{"timestamp", Time(stamp_ns)},
        {"frame_id", Cam(m.camera_id)},
        {"width", m.width},
        {"height", m.height},
        {"distortion_model", "plumb_bob"},
        {"D", std::vector<double>(m.distortion, m.distortion + 5)},
        {"K", K},
        {"R", {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0}},
        {"P", P}});
  // world_from_cam: the camera's pose in the world (x_world = R^T (x_cam - t)).
  Eigen::Matrix3d R;
  for (int i = 0; i < 9; ++i) R(i / 3, i % 3) = m.cam_from_world_rotation[i];
  const Eigen::Vector3d t(m.cam_from_world_translation[0], m.cam_from_world_translation[1],
                          m.cam_from_world_translation[2]);
  const Eigen::Vector3d centre = -R.transpose() * t;
  const Eigen::Quaterniond q(R.transpose());
  Json("/foxglove/tf", "foxglove.FrameTransforms", kFrameTransforms.c_str(), stamp_ns,
       {{"transforms",
         {{{"timestamp", Time(stamp_ns)},
           {"parent_frame_id", "world"},
           {"child_frame_id", Cam(m.camera_id)},
           {"translation", {{"x", centre.x()}, {"y", centre.y()}, {"z", centre.z()}}},
           {"rotation", {{"x", q.x()}, {"y", q.y()}, {"z", q.z()}, {"w", q.w()}}}}}}});
}

void FoxgloveExport::Image(int64_t stamp_ns, uint32_t camera_id, const cv::Mat& bgr) {
  Compressed("/foxglove/" + Cam(camera_id) + "/image", stamp_ns, Cam(camera_id), bgr, "jpeg");
}

void FoxgloveExport::Map(int64_t stamp_ns, uint32_t camera_id, const cv::Mat& map) {
  Compressed("/foxglove/" + Cam(camera_id) + "/object_pixel_map", stamp_ns, Cam(camera_id), map, "png");
}

void FoxgloveExport::HullView(int64_t stamp_ns, const cv::Mat& bgr) {
  Compressed("/foxglove/hull_view", stamp_ns, "view", bgr, "jpeg");
}

void FoxgloveExport::HullPoints(int64_t stamp_ns, const NovelView& view, const cv::Mat& depth) {
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
  const Eigen::Vector3d& t = view.world_from_eye.translation;
  const Eigen::Quaterniond q(view.world_from_eye.rotation);
  json fields = json::array();
  int offset = 0;
  for (const char* name : {"x", "y", "z", "depth"}) {
    fields.push_back({{"name", name}, {"offset", offset}, {"type", 7}});
    offset += 4;
  }
  Json("/foxglove/hull_points", "foxglove.PointCloud", kPointCloud.c_str(), stamp_ns,
       {{"timestamp", Time(stamp_ns)},
        {"frame_id", "world"},
        {"pose",
         {{"position", {{"x", t.x()}, {"y", t.y()}, {"z", t.z()}}},
          {"orientation", {{"x", q.x()}, {"y", q.y()}, {"z", q.z()}, {"w", q.w()}}}}},
        {"point_stride", 16},
        {"fields", fields},
        {"data", Base64(data)}});
}

void FoxgloveExport::Object(int64_t stamp_ns, const VirtualObjectSample& o) {
  Json("/foxglove/scene", "foxglove.SceneUpdate", kSceneUpdate.c_str(), stamp_ns,
       {{"deletions", json::array()},
        {"entities", {Entity(stamp_ns, "ball" + std::to_string(o.object_id),
                             json::array({Sphere(o.position, 2 * o.radius, o.colliding)}))}}});
}

void FoxgloveExport::Collision(int64_t stamp_ns, const hullpipe_msg_CollisionReport& m) {
  json spheres = json::array();
  for (uint32_t i = 0; i < m.collision_points._length; ++i) {
    const auto& p = m.collision_points._buffer[i];
    spheres.push_back(Sphere(Eigen::Vector3d(p.x, p.y, p.z), 0.01, true));
  }
  Json("/foxglove/scene", "foxglove.SceneUpdate", kSceneUpdate.c_str(), stamp_ns,
       {{"deletions", json::array()},
        {"entities", {Entity(stamp_ns, "collision_points" + std::to_string(m.object_id), spheres)}}});
}

void FoxgloveExport::Stats(int64_t stamp_ns, const NodeStatsSample& st) {
  Json("/foxglove/node_stats", "hullpipe.NodeStatsPlot", kNodeStatsPlot.c_str(), stamp_ns,
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

}  // namespace hullpipe::record
