#include "record_ros2.h"

#include <type_traits>

#include "hullpipe/ros2/ros2_schemas.h"

namespace hullpipe::record {
namespace {

WriterOptions McapRos2() {
  WriterOptions o;
  o.storage = Storage::kMcap;
  o.compression = Compression::kZstd;
  o.mcap.profile = "ros2";
  return o;
}

}  // namespace

Ros2Export::Ros2Export(const std::string& path, const dds::Participant& participant)
    : path_(path),
      participant_(participant),
      w_(path, McapRos2()),
      deriver_({}, [this](const ros2::Ros2Message& m) { Write(m.topic, m.type, m.qos, m.msg, log_ns_, m.stamp_ns); }) {
  w_.SetMeta("ros2", "hullpipe's topics as ROS 2 Humble messages, by hullpipe_record export --ros2 (docs/ros2.md)");
}

const dds::CdrWriter& Ros2Export::Codec(const std::string& type) {
  auto& c = codecs_[type];
  if (!c) {
    const dds::KnownType* hullpipe = dds::FindKnownType(type);
    const dds::KnownType kt = hullpipe ? *hullpipe : ros2::Ros2KnownType(type);
    c = std::make_unique<dds::CdrWriter>(participant_, kt, kt.qos, dds::CdrWriter::Scope::kDecodeOnly);
  }
  return *c;
}

void Ros2Export::Write(const std::string& ros_topic, const std::string& type, const dds::QosSpec& qos,
                       const void* msg, int64_t log_ns, int64_t stamp_ns) {
  auto it = ids_.find(ros_topic);
  if (it == ids_.end()) {
    TopicInfo t;
    t.name = ros_topic;  // rosbag2 keeps the ROS name
    t.type = type;
    t.reliable = qos.reliable;
    t.transient_local = qos.transient_local;
    t.depth = qos.depth;
    t.type_description = ros2::Ros2MsgSchema(type);
    t.schema_encoding = "ros2msg";
    t.message_encoding = "cdr";
    t.offered_qos_profiles = ros2::OfferedQosProfiles(qos);
    it = ids_.emplace(ros_topic, w_.AddTopic(t)).first;
  }
  Sample s;
  s.topic_id = it->second;
  s.arrival_ns = log_ns;
  s.source_ns = stamp_ns;
  s.data = Codec(type).Encode(msg);
  w_.Append(s);
  ++counts_[ros_topic];
  if (++appended_ % 64 == 0) w_.Commit();
}

bool Ros2Export::Add(const TopicInfo& topic, const Sample& sample) {
  const std::string& type = topic.type;
  log_ns_ = sample.arrival_ns;
  std::string why;
  auto with = [&](auto tag, auto&& derive) {
    using T = typename decltype(tag)::type;
    return Codec(type).template DecodeWith<T>(sample.data, [&](const T& m) { why = derive(m); });
  };
  bool decoded = true;
  if (type == "hullpipe::msg::CameraInfo")
    decoded = with(std::type_identity<hullpipe_msg_CameraInfo>{},
                   [&](const auto& m) { return deriver_.OnCameraInfo(m, log_ns_); });
  else if (type == "hullpipe::msg::ObjectPixelMap")
    decoded = with(std::type_identity<hullpipe_msg_ObjectPixelMap>{}, [&](const auto& m) { return deriver_.OnMap(m); });
  else if (type == "hullpipe::msg::CameraImage")
    decoded = with(std::type_identity<hullpipe_msg_CameraImage>{}, [&](const auto& m) { return deriver_.OnImage(m); });
  else if (type == "hullpipe::msg::ViewPose")
    decoded = with(std::type_identity<hullpipe_msg_ViewPose>{}, [&](const auto& m) { return deriver_.OnViewPose(m); });
  else if (type == "hullpipe::msg::HullView")
    decoded = with(std::type_identity<hullpipe_msg_HullView>{}, [&](const auto& m) { return deriver_.OnHullView(m); });
  else if (type == "hullpipe::msg::CompositedView")
    decoded = with(std::type_identity<hullpipe_msg_CompositedView>{},
                   [&](const auto& m) { return deriver_.OnCompositedView(m); });
  else if (type == "hullpipe::msg::VirtualObjectState")
    decoded = with(std::type_identity<hullpipe_msg_VirtualObjectState>{},
                   [&](const auto& m) { return deriver_.OnObjectState(m); });
  else if (type == "hullpipe::msg::CollisionReport")
    decoded = with(std::type_identity<hullpipe_msg_CollisionReport>{},
                   [&](const auto& m) { return deriver_.OnCollisionReport(m); });
  else if (type == "hullpipe::msg::VirtualMesh")
    decoded = with(std::type_identity<hullpipe_msg_VirtualMesh>{}, [&](const auto& m) { return deriver_.OnMesh(m); });
  else if (type == "hullpipe::msg::ModelPart")
    decoded =
        with(std::type_identity<hullpipe_msg_ModelPart>{}, [&](const auto& m) { return deriver_.OnModelPart(m); });
  else if (type == "hullpipe::msg::ModelState")
    decoded =
        with(std::type_identity<hullpipe_msg_ModelState>{}, [&](const auto& m) { return deriver_.OnModelState(m); });
  return decoded && why.empty();
}

}  // namespace hullpipe::record
